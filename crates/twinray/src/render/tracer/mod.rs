//! The Whitted tracer over packets of rays, one lane per view.
//!
//! A packet of one lane is an ordinary ray: the reference renders use that.
//! The twin method gives the tracer the views' samples of one surface point as
//! one packet (see `render`): their shadow rays toward each light go as one
//! packet, and their reflected (and refracted) rays too, recursively — each
//! lane's ray is its own view's, the descent of the hierarchy is shared. Each
//! lane's numbers are its own throughout, so every lane gets exactly what its
//! view's reference render gets.

mod lean_surfaces;
mod merged_rays;

pub(super) use lean_surfaces::flat_materials;
#[cfg(test)]
pub(super) use lean_surfaces::tests::{scene as test_scene, unlit as unlit_test_scene};

use crate::bvh::{
    segment_enters, Bvh, NearestTest, Packet, PacketHits, SegmentPacket, TraversalStats, EYE_PACKET,
};
use crate::math::{reflect, refract, Color, Ray, Vec3};
use crate::render::counts::TraceCounts;
use crate::render::options::{TraceSettings, MAX_LANES};
use crate::shading::{
    blocks, light_contribution, offset_point, shadow_packet, toward_light, SurfacePoint,
};
use crate::shapes::{BlockHits, EightHits, EightRays, Shape, SurfaceHit, Triangle4};
use crate::world::{World, MAX_CUTOUT_LAYERS};
use wide::f32x8;

pub struct Tracer<'a> {
    pub world: &'a World,
    pub settings: TraceSettings,
    pub counts: TraceCounts,
    traversal: TraversalStats,
    /// Per ray level, light and lane, the opaque primitive that blocked the
    /// last traced shadow ray toward the light from a hit of that level,
    /// `None` if nothing opaque did (index `cache_slot`). One slot per level:
    /// consecutive eye hits are near each other, and so are their reflections,
    /// but an eye hit and its reflection's hit are not. A lit segment clears
    /// its slot: a stale blocker would be tested in vain by the next segments
    /// (docs/decisions.md).
    shadow_cache: Vec<Option<u32>>,
    /// The fast method's shading cache of the current row, shared by its
    /// batches of views (a tracer serves one task, whose rows are traced in
    /// order).
    pub(in crate::render) shading_cache: crate::render::fast::shading_cache::ShadingCache,
    /// Hits whose shading reads no normal skip it (`lean_surfaces`); off
    /// only in the test that compares against the full computation.
    lean_surfaces: bool,
}

/// How the lanes' reflected and refracted rays are traced.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SecondaryRays {
    /// Every lane traces its own rays, the lanes as one packet (exact).
    #[default]
    Own,
    /// The paper's section 2.4 (approximate): lanes whose hits lie on one
    /// planar surface trace one reflected (refracted) ray for all, from the
    /// midpoint.
    MergedOnPlanes,
}

/// What one shading call carries down its tree of rays: how it traces the
/// secondary rays, and the largest specular or transmission coefficient of
/// the surfaces it shaded (whether the tree was diffuse, section 2.5).
struct ShadingTree {
    secondary: SecondaryRays,
    largest_coefficient: f32,
    /// Per lane of the top packet (of at most `EYE_PACKET` lanes), the
    /// largest coefficient of its own rays' surfaces: each donor of a packet
    /// of donors (`shade_donors`) is judged on its own tree, as alone.
    lane_largest: [f32; EYE_PACKET],
    /// The lanes of the top packet whose rays the current packet of one lane
    /// carries: a packet of several lanes keeps its lanes in their places
    /// (`trace_spawned`), one of one lane does not (one lane's ray alone, or
    /// merged lanes' one ray). Lane 0 at the top.
    single: u32,
    /// Under `MergedOnPlanes`, per lane of the top packet (of eight lanes),
    /// the group of views it belongs to: only lanes of one group merge their
    /// rays (section 2.4 merges the views' rays of one point, not those of
    /// neighbouring samples that a packet of several groups holds). `None`:
    /// the packet is one group.
    groups: Option<[u8; EYE_PACKET]>,
}

impl ShadingTree {
    fn new(secondary: SecondaryRays) -> ShadingTree {
        ShadingTree {
            secondary,
            largest_coefficient: 0.0,
            lane_largest: [0.0; EYE_PACKET],
            single: 1,
            groups: None,
        }
    }

    /// The lanes of the top packet that `lanes` of a packet of `K` lanes are.
    fn top_lanes<const K: usize>(&self, lanes: u32) -> u32 {
        if K == 1 {
            self.single
        } else {
            lanes
        }
    }

    /// Lane `l` of a packet of `K` lanes shaded a surface of specular or
    /// transmission coefficient (or uncovered share) `c`.
    fn note<const K: usize>(&mut self, l: usize, c: f32) {
        self.largest_coefficient = self.largest_coefficient.max(c);
        let mut lanes = self.top_lanes::<K>(1 << l);
        while lanes != 0 {
            let top = lanes.trailing_zeros() as usize;
            lanes &= lanes - 1;
            if let Some(largest) = self.lane_largest.get_mut(top) {
                *largest = largest.max(c);
            }
        }
    }

    /// Whether lanes `l` and `m` of a packet of `K` lanes belong to one group.
    fn one_group<const K: usize>(&self, l: usize, m: usize) -> bool {
        match self.groups {
            Some(groups) if K > 1 => groups.get(l) == groups.get(m),
            _ => true,
        }
    }
}

/// What shading's first stage found at a packet's hits.
struct Surfaces<'a, const K: usize> {
    points: [Option<SurfacePoint<'a>>; K],
    prims: [u32; K],
    /// Ambient term of lanes with a hit, the background for the others.
    ambient: [Color; K],
    /// Lanes with a hit whose material takes light.
    lit: u32,
    reflected: [Option<Spawn>; K],
    refracted: [Option<Spawn>; K],
    /// Share of each lane's surface that is there (BLEND alpha; else 1).
    coverage: [f32; K],
    /// The rays that go straight on through the uncovered share (BLEND).
    passed: [Option<Spawn>; K],
}

/// Ray levels with shadow cache slots of their own (`Tracer::shadow_cache`).
const CACHED_LEVELS: usize = 8;

/// A transmittance handed to [`Tracer::shade_from_donors`] that means: trace
/// this lane's own shadow ray toward the light.
pub const TRACE_LIGHT: f32 = -1.0;

/// A surface point's shading, kept so that other views' samples that see the
/// same point can take it (the paper's section 2.5): what reached it from each
/// light, and the weighted colour of its reflected and refracted rays.
#[derive(Clone, Debug, Default)]
pub struct Donor {
    pub color: Color,
    /// Transmittance toward each light (0 where the surface faces away).
    pub through: Vec<f32>,
    /// Sum of coefficient × colour of the secondary rays.
    pub secondary: Color,
    /// Largest specular or transmission coefficient over the shading tree.
    pub tree_coefficient: f32,
}

/// What `Donor` keeps, for each lane of a packet of donors (`shade_donors`).
#[derive(Clone, Debug, Default)]
pub struct Donors {
    pub colors: [Color; EYE_PACKET],
    /// Transmittance toward each light, lane `l`'s at `l * lights..`.
    pub through: Vec<f32>,
    pub secondary: [Color; EYE_PACKET],
    pub tree_coefficients: [f32; EYE_PACKET],
}

impl Donors {
    /// Lane `l`'s transmittance toward each of `lights` lights.
    pub fn through(&self, l: usize, lights: usize) -> &[f32] {
        &self.through[l * lights..(l + 1) * lights]
    }
}

/// The colour of a reflected ray of weight `mirror`: the material's own
/// mirror (`material.mirror`) tinted by its specular colour (a metal's base
/// colour), and what total internal reflection hands over of the
/// transmission (the rest) untinted. White, exactly, for every material
/// without a coloured specular (NFF's, OBJ's): their images do not change.
fn mirror_tint(material: &crate::scene::Material, mirror: f32) -> Color {
    let spec = material.specular_color;
    if spec == Color::ONE {
        return Color::ONE;
    }
    let own = material.mirror;
    if mirror <= own {
        return spec;
    }
    (spec * own + Color::splat(mirror - own)) / mirror
}

/// A secondary ray one lane wants traced, and its weight in the lane's colour.
#[derive(Clone, Copy)]
struct Spawn {
    origin: Vec3,
    dir: Vec3,
    coefficient: f32,
    /// Colour the ray's light is multiplied by (with `coefficient`): a
    /// metal's mirror takes its base colour, as a conductor's Fresnel
    /// reflectance at normal incidence is; white otherwise.
    tint: Color,
}

impl<'a> Tracer<'a> {
    pub fn new(world: &'a World, settings: TraceSettings) -> Tracer<'a> {
        Tracer {
            world,
            settings,
            counts: TraceCounts::default(),
            traversal: TraversalStats::default(),
            shadow_cache: vec![None; CACHED_LEVELS * world.scene.lights.len() * MAX_LANES],
            shading_cache: Default::default(),
            lean_surfaces: true,
        }
    }

    /// The counters, with the hierarchy's work folded in.
    pub fn finish(mut self) -> TraceCounts {
        self.counts.add_traversal(&self.traversal);
        self.counts
    }

    /// Eye rays, each lane tracing its own secondary rays: lane `l` belongs
    /// to view `views[l]`.
    pub fn trace_eye<const K: usize>(
        &mut self,
        packet: &Packet<K>,
        views: &[usize; K],
    ) -> [Color; K] {
        let hits = self.eye_hits(packet, views);
        let mut tree = ShadingTree::new(SecondaryRays::Own);
        self.shade(packet, &hits, 1, [1.0; K], &mut tree)
    }

    /// The nearest hit of every lane of an eye-ray packet (one descent for all
    /// views); lane `l` belongs to view `views[l]`.
    pub fn eye_hits<const K: usize>(
        &mut self,
        packet: &Packet<K>,
        views: &[usize; K],
    ) -> PacketHits<K> {
        let hits = self.closest(packet);
        self.count_eye_hits(packet, &hits, views);
        hits
    }

    /// Whether `eye_hit` may trace this world's eye rays: where `closest`
    /// would take the eight-wide descent for a ray alone (no cut-outs, no
    /// cut, the wide tree built).
    pub fn eye_hit_applies(&self) -> bool {
        let world = self.world;
        !(world.has_alpha || world.far.is_some() || world.bvh.wide.is_empty())
    }

    /// `eye_hits` for one ray (lane 0 of `packet`, of view `view`) where
    /// `eye_hit_applies`: `closest`'s eight-wide descent inlined, the same
    /// hit, counted the same, without the calls between. Its caller keeps
    /// the other path in a loop of its own, so that the answer is never
    /// merged into a value returned through memory (whose reload stalls).
    #[inline(always)]
    pub fn eye_hit(&mut self, packet: &Packet<1>, view: usize) -> (u32, SurfaceHit) {
        let world = self.world;
        let test = NearestShape {
            shapes: &world.scene.shapes,
            packet,
            eight: None,
        };
        let (prim, hit) = world.bvh.closest_ray(packet, &mut self.traversal, test);
        self.counts.closest_traversals += 1;
        self.counts.eye_traversals += 1;
        if packet.mask & 1 != 0 {
            self.counts.rays.eye += 1;
            if prim != PacketHits::<1>::NO_HIT {
                self.counts.rays.eye_hit += 1;
                if let Some(h) = self.counts.per_view_hits.0.get_mut(view) {
                    *h += 1;
                }
            }
        }
        (prim, hit)
    }

    /// `eye_hit` for up to eight neighbouring eye rays (the lanes of
    /// `packet.mask`, lane `l` of view `views[l]`: one view's neighbouring
    /// samples, or a few samples of a batch of views) in one descent
    /// (`Bvh::closest_packet8`): each lane's hit bit for bit `eye_hit`'s,
    /// counted as `eye_hit` counts it, the packet counted, and one
    /// traversal (one descent; a batch's packet of views also counts one). `None`
    /// (nothing traced, nothing counted) where the packet does not apply: the
    /// caller traces the rays alone. Only where `eye_hit_applies`.
    #[inline]
    pub fn eye_hits8(
        &mut self,
        packet: &Packet<EYE_PACKET>,
        views: &[usize; EYE_PACKET],
    ) -> Option<PacketHits<EYE_PACKET>> {
        let world = self.world;
        let test = NearestShape {
            shapes: &world.scene.shapes,
            packet,
            eight: None,
        };
        let hits = world
            .bvh
            .closest_packet8(packet, &mut self.traversal, test)?;
        let rays = (packet.mask & 0xff).count_ones() as u64;
        self.counts.eye_packets += 1;
        self.counts.eye_packet_rays += rays;
        // One descent, as a batch's packet of views counts one.
        self.counts.closest_traversals += 1;
        self.counts.eye_traversals += 1;
        self.counts.rays.eye += rays;
        for l in (0..EYE_PACKET).filter(|&l| packet.mask & (1 << l) != 0 && hits.has_hit(l)) {
            self.counts.rays.eye_hit += 1;
            if let Some(h) = self.counts.per_view_hits.0.get_mut(views[l]) {
                *h += 1;
            }
        }
        Some(hits)
    }

    /// Eye rays and their hits, per view.
    pub fn count_eye_hits<const K: usize>(
        &mut self,
        packet: &Packet<K>,
        hits: &PacketHits<K>,
        views: &[usize; K],
    ) {
        self.counts.eye_traversals += 1;
        let mut lanes = packet.mask;
        while lanes != 0 {
            let l = lanes.trailing_zeros() as usize;
            lanes &= lanes - 1;
            self.counts.rays.eye += 1;
            if hits.has_hit(l) {
                self.counts.rays.eye_hit += 1;
                if let Some(h) = self.counts.per_view_hits.0.get_mut(views[l]) {
                    *h += 1;
                }
            }
        }
    }

    /// Shades eye rays whose hits are known (`eye_hits`), the lanes together
    /// (samples of several views: counted as grouped).
    pub fn shade_eye<const K: usize>(
        &mut self,
        packet: &Packet<K>,
        hits: &PacketHits<K>,
        secondary: SecondaryRays,
    ) -> [Color; K] {
        let lanes = packet.mask.count_ones() as u64;
        if lanes > 1 {
            self.counts.grouped_samples += lanes;
        }
        self.shade_eye_lanes(packet, hits, secondary)
    }

    /// `shade_eye` for lanes of one view (a mono row's neighbouring
    /// samples), not counted as grouped.
    pub fn shade_eye_lanes<const K: usize>(
        &mut self,
        packet: &Packet<K>,
        hits: &PacketHits<K>,
        secondary: SecondaryRays,
    ) -> [Color; K] {
        let mut tree = ShadingTree::new(secondary);
        self.shade(packet, hits, 1, [1.0; K], &mut tree)
    }

    /// Shades one eye ray's known hit (lane 0 of `packet`) and keeps what other
    /// views may reuse of it (`Donor`), in `donor` (its buffers are reused).
    pub fn shade_donor(
        &mut self,
        packet: &Packet<1>,
        hits: &PacketHits<1>,
        secondary: SecondaryRays,
        donor: &mut Donor,
    ) {
        donor.through.clear();
        donor.through.resize(self.world.scene.lights.len(), 0.0);
        donor.secondary = Color::ZERO;
        let mut tree = ShadingTree::new(secondary);
        let record = Some((
            &mut donor.through[..],
            std::slice::from_mut(&mut donor.secondary),
        ));
        donor.color = self.shade_stages(packet, hits, 1, [1.0], &mut tree, record)[0];
        donor.tree_coefficient = tree.largest_coefficient;
    }

    /// `shade_donor` for the lanes of a packet of eye rays at once (the
    /// donors of neighbouring samples: their shadow segments and secondary
    /// rays go down in the eight-lane descents). Each lane's colour, light
    /// and secondary colour are what it gets alone (its own rays; no two
    /// lanes merge theirs, as a one-lane tree merges nothing), and so is its
    /// tree's largest coefficient (its own surfaces'). Into `donors` (its
    /// buffers are reused).
    pub fn shade_donors(
        &mut self,
        packet: &Packet<EYE_PACKET>,
        hits: &PacketHits<EYE_PACKET>,
        secondary: SecondaryRays,
        donors: &mut Donors,
    ) {
        donors.through.clear();
        donors
            .through
            .resize(self.world.scene.lights.len() * EYE_PACKET, 0.0);
        donors.secondary = [Color::ZERO; EYE_PACKET];
        let mut tree = ShadingTree::new(secondary);
        tree.groups = Some(std::array::from_fn(|l| l as u8));
        let record = Some((&mut donors.through[..], &mut donors.secondary[..]));
        let weights = [1.0; EYE_PACKET];
        donors.colors = self.shade_stages(packet, hits, 1, weights, &mut tree, record);
        donors.tree_coefficients = tree.lane_largest;
    }

    /// `shade_eye_lanes` for a packet of eight lanes from several groups of
    /// views (lane `l` of group `groups[l]`): merged secondary rays
    /// (`MergedOnPlanes`) join only lanes of one group, as when each group
    /// is shaded as a packet of its own.
    pub fn shade_eye_groups(
        &mut self,
        packet: &Packet<EYE_PACKET>,
        hits: &PacketHits<EYE_PACKET>,
        secondary: SecondaryRays,
        groups: [u8; EYE_PACKET],
    ) -> [Color; EYE_PACKET] {
        let mut tree = ShadingTree::new(secondary);
        tree.groups = Some(groups);
        self.shade(packet, hits, 1, [1.0; EYE_PACKET], &mut tree)
    }

    /// The colours of eye rays' own hits, their lights' visibility and
    /// secondary colours taken from other views' samples of nearby points
    /// of the same surface (the ambient, diffuse and highlight terms are
    /// each ray's own: the highlight depends on the view): lane `l` takes the
    /// transmittances `through[l * lights..]` and the secondary colour
    /// `secondary[l]` (each lane's colour is what it gets alone). A
    /// transmittance below 0 (`TRACE_LIGHT`) is the lane's own: its shadow
    /// ray is traced, as the exact shading traces it, and what it found is
    /// written in its place (0 where the point faces away from the light).
    pub fn shade_from_donors<const K: usize>(
        &mut self,
        packet: &Packet<K>,
        hits: &PacketHits<K>,
        through: &mut [f32],
        secondary: &[Color; K],
    ) -> [Color; K] {
        // At the deepest level: no secondary ray is spawned (the donor's are taken).
        let mut tree = ShadingTree::new(SecondaryRays::Own);
        let s = self.surfaces(packet, hits, self.settings.max_depth, [1.0; K], &mut tree);
        let mut out = s.ambient;
        let scene = &self.world.scene;
        let lights = scene.lights.len();
        for (i, light) in scene.lights.iter().enumerate() {
            // The lanes that trace their own shadow ray toward this light go
            // as one packet, from the point the exact shading starts it at.
            let mut seg = SegmentPacket::<K>::empty();
            let mut toward = [None; K];
            let mut lanes = packet.mask & s.lit;
            while lanes != 0 {
                let l = lanes.trailing_zeros() as usize;
                lanes &= lanes - 1;
                let t = through.get(l * lights + i).copied().unwrap_or(0.0);
                let Some(sp) = &s.points[l] else {
                    continue;
                };
                if t == 0.0 {
                    continue;
                }
                toward[l] = toward_light(sp, light);
                if let (Some((dir, dist, _)), true) = (toward[l], t < 0.0) {
                    seg.origins[l] = offset_point(sp.point, sp.offset_normal, sp.t);
                    seg.dirs[l] = dir;
                    seg.t_max[l] = dist;
                    seg.mask |= 1 << l;
                }
            }
            let own = if seg.mask != 0 {
                self.light_transmittance(i, 1, &mut seg)
            } else {
                [0.0; K]
            };
            for (l, toward) in toward.iter().enumerate() {
                let slot = l * lights + i;
                if through.get(slot).is_some_and(|&t| t < 0.0) {
                    through[slot] = if seg.mask & (1 << l) != 0 {
                        own[l]
                    } else {
                        0.0
                    };
                }
                let (Some(sp), Some((dir, _, color))) = (&s.points[l], toward) else {
                    continue;
                };
                let t = through.get(slot).copied().unwrap_or(0.0);
                if t > 0.0 {
                    out[l] +=
                        light_contribution(sp, packet.dirs[l], *dir, *color, t * s.coverage[l]);
                }
            }
        }
        let mut lanes = packet.mask;
        while lanes != 0 {
            let l = lanes.trailing_zeros() as usize;
            lanes &= lanes - 1;
            if s.points[l].is_some() {
                out[l] += secondary[l];
            }
        }
        out
    }

    /// The nearest hit of every lane, in the whole scene, past cut-outs.
    fn closest<const K: usize>(&mut self, packet: &Packet<K>) -> PacketHits<K> {
        let mut hits = self.closest_near_far(packet);
        if self.world.has_alpha {
            self.past_cutouts(packet, &mut hits, |t, p| t.closest_near_far(p));
        }
        hits
    }

    /// Lanes whose nearest hit lands on a cut-away part of a MASK material go
    /// on past it, each alone: the same ray with `t_min` raised to the hit
    /// (`nearest` traces it), until it meets a part that is there or nothing.
    /// A lane's answer depends on its own ray only, never on the packet it
    /// came in, so the twin and the independent renders stay bit-identical;
    /// and the traversal is not involved.
    fn past_cutouts<const K: usize>(
        &mut self,
        packet: &Packet<K>,
        hits: &mut PacketHits<K>,
        mut nearest: impl FnMut(&mut Self, &Packet<1>) -> PacketHits<1>,
    ) {
        let scene = &self.world.scene;
        let mut lanes = packet.mask;
        while lanes != 0 {
            let l = lanes.trailing_zeros() as usize;
            lanes &= lanes - 1;
            let mut layers = 0;
            while hits.has_hit(l) && scene.cut_away(hits.prim[l] as usize, &hits.hit[l]) {
                layers += 1;
                if layers > MAX_CUTOUT_LAYERS {
                    break; // the ray stops at the last layer it reached
                }
                self.counts.cutout_continuations += 1;
                let on = Packet {
                    origins: [packet.origins[l]],
                    dirs: [packet.dirs[l]],
                    t_min: hits.hit[l].t,
                    t_max: [packet.t_max[l]],
                    mask: 1,
                };
                let next = nearest(self, &on);
                hits.prim[l] = next.prim[0];
                hits.hit[l] = next.hit[0];
            }
        }
    }

    /// The nearest hit of every lane among all primitives, cut away or not.
    fn closest_near_far<const K: usize>(&mut self, packet: &Packet<K>) -> PacketHits<K> {
        let world = self.world;
        let mut hits = self.closest_in(&world.bvh, packet);
        if let Some(far) = &world.far {
            // Beyond the cut (section 2.3): only what is nearer than the near hit.
            let mut nearer = *packet;
            for l in 0..K {
                nearer.t_max[l] = nearer.t_max[l].min(hits.hit[l].t);
            }
            let far_hits = self.closest_in(far, &nearer);
            for l in 0..K {
                if far_hits.has_hit(l) {
                    hits.prim[l] = far_hits.prim[l];
                    hits.hit[l] = far_hits.hit[l];
                }
            }
        }
        hits
    }

    fn closest_in<const K: usize>(&mut self, bvh: &Bvh, packet: &Packet<K>) -> PacketHits<K> {
        self.counts.closest_traversals += 1;
        let test = NearestShape {
            shapes: &self.world.scene.shapes,
            packet,
            eight: None,
        };
        bvh.closest(packet, &mut self.traversal, test)
    }

    /// With a cut (section 2.3), the eye pass's two parts: the nearest hits
    /// among the objects nearer than the cut (`near`), or beyond it (`!near`).
    /// Counted by the caller (`count_eye_hits`) once it has combined them.
    pub fn eye_hits_split<const K: usize>(
        &mut self,
        packet: &Packet<K>,
        near: bool,
    ) -> PacketHits<K> {
        let world = self.world;
        let part = match (&world.far, near) {
            (Some(far), false) => far,
            (Some(_), true) => &world.bvh,
            (None, _) => return self.closest(packet),
        };
        let mut hits = self.closest_in(part, packet);
        if world.has_alpha {
            self.past_cutouts(packet, &mut hits, |t, p| t.closest_in(part, p));
        }
        hits
    }

    /// Traces a secondary packet at `level`.
    fn trace<const K: usize>(
        &mut self,
        packet: &Packet<K>,
        level: u32,
        weights: [f32; K],
        tree: &mut ShadingTree,
    ) -> [Color; K] {
        let hits = self.closest(packet);
        self.shade(packet, &hits, level, weights, tree)
    }

    /// Whitted shading of a packet's hits, in three stages: the surfaces hit
    /// (points, normals, ambient term, the rays they spawn), direct light
    /// (shadow rays toward each light, the lanes as one packet), and the
    /// secondary rays (reflected, then refracted, the lanes as one packet).
    fn shade<const K: usize>(
        &mut self,
        packet: &Packet<K>,
        hits: &PacketHits<K>,
        level: u32,
        weights: [f32; K],
        tree: &mut ShadingTree,
    ) -> [Color; K] {
        self.shade_stages(packet, hits, level, weights, tree, None)
    }

    /// `shade`'s stages; with `record`, each lane's transmittance toward each
    /// light (lane `l`'s at `l * lights..`, zeroed by the caller) and its
    /// weighted secondary colour are written there (`shade_donor`,
    /// `shade_donors`).
    fn shade_stages<const K: usize>(
        &mut self,
        packet: &Packet<K>,
        hits: &PacketHits<K>,
        level: u32,
        weights: [f32; K],
        tree: &mut ShadingTree,
        record: Option<(&mut [f32], &mut [Color])>,
    ) -> [Color; K] {
        let (through, secondary) = record.unzip();
        let surfaces = self.surfaces(packet, hits, level, weights, tree);
        let mut out = surfaces.ambient;
        self.direct_light(packet, &surfaces, &mut out, through, level);
        if level < self.settings.max_depth {
            self.secondary(&surfaces, level, &weights, tree, &mut out, secondary);
        }
        out
    }

    /// Stage 1: what each lane hit, its ambient term, and the reflected and
    /// refracted rays it wants traced.
    fn surfaces<const K: usize>(
        &mut self,
        packet: &Packet<K>,
        hits: &PacketHits<K>,
        level: u32,
        weights: [f32; K],
        tree: &mut ShadingTree,
    ) -> Surfaces<'a, K> {
        let world = self.world;
        let scene = &world.scene;
        let mut s = Surfaces {
            points: [None; K],
            prims: [PacketHits::<K>::NO_HIT; K],
            ambient: [scene.background; K],
            lit: 0,
            reflected: [None; K],
            refracted: [None; K],
            coverage: [1.0; K],
            passed: [None; K],
        };
        let spawn_more = level < self.settings.max_depth;
        let mut lanes = packet.mask;
        while lanes != 0 {
            let l = lanes.trailing_zeros() as usize;
            lanes &= lanes - 1;
            if !hits.has_hit(l) {
                s.ambient[l] = scene.background_toward(packet.dirs[l]);
                continue;
            }
            let prim = hits.prim[l] as usize;
            let hit = &hits.hit[l];
            let d = packet.dirs[l];
            let shape = &scene.shapes[prim];
            let (sp, ambient, coverage) =
                self.surface_point(packet.origins[l], d, prim, hit, spawn_more);
            let (material, point) = (sp.material, sp.point);
            let (facing, off) = (sp.normal, sp.offset_normal);
            tree.note::<K>(
                l,
                material
                    .ks
                    .max(material.mirror)
                    .max(material.t)
                    .max(1.0 - coverage),
            );
            s.ambient[l] = ambient;
            s.coverage[l] = coverage;
            s.prims[l] = prim as u32;
            s.points[l] = Some(sp);
            if material.kd > 0.0 || material.ks > 0.0 {
                s.lit |= 1 << l;
            }
            if !spawn_more {
                continue;
            }
            if coverage < 1.0 && self.wanted(weights[l] * (1.0 - coverage)) {
                s.passed[l] = Some(Spawn {
                    origin: offset_point(point, -off, hit.t),
                    dir: d,
                    coefficient: 1.0 - coverage,
                    tint: Color::ONE,
                });
            }
            // Transmission first: total internal reflection hands its weight to the mirror.
            let mut mirror = material.mirror * coverage;
            let transmission = material.t * coverage;
            if material.t > 0.0 {
                let entering = shape.met_from_front(point, d);
                match refract(d, facing, material.eta(entering)) {
                    Some(dir) => {
                        if self.wanted(weights[l] * transmission) {
                            s.refracted[l] = Some(Spawn {
                                origin: offset_point(point, -off, hit.t),
                                dir,
                                coefficient: transmission,
                                tint: Color::ONE,
                            });
                        }
                    }
                    None => mirror += transmission,
                }
            }
            let spd_forces = self.settings.spd && (material.mirror > 0.0 || material.t > 0.0);
            if (mirror > 0.0 && self.wanted(weights[l] * mirror)) || spd_forces {
                s.reflected[l] = Some(Spawn {
                    origin: offset_point(point, off, hit.t),
                    dir: reflect(d, facing),
                    coefficient: mirror,
                    tint: mirror_tint(material, mirror),
                });
            }
        }
        s
    }

    /// The surface point a ray from `origin` along `d` hits (`prim`, `hit`),
    /// its normal turned to face the ray, its ambient term (times its
    /// coverage) and its coverage. `spawn`: whether the hit may still spawn
    /// rays (else a hit that takes no light skips its normal).
    #[inline(always)]
    fn surface_point(
        &self,
        origin: Vec3,
        d: Vec3,
        prim: usize,
        hit: &SurfaceHit,
        spawn: bool,
    ) -> (SurfacePoint<'a>, Color, f32) {
        let world = self.world;
        let scene = &world.scene;
        let point = origin + d * hit.t;
        let surface = match self.lean_surfaces
            && !lean_surfaces::needs_normal(scene, world.material_of(prim as u32), spawn)
        {
            true => scene.surface_colour_at(prim, hit),
            false => scene.surface_at(prim, hit, point),
        };
        let (material, normal) = (surface.material, surface.normal);
        let coverage = surface.coverage;
        let facing = if normal.dot(d) < 0.0 { normal } else { -normal };
        // Rays leave along the normal before a normal map bent it.
        let unbent = surface.offset_normal;
        let off = if unbent.dot(d) < 0.0 { unbent } else { -unbent };
        let sp = SurfacePoint {
            point,
            normal: facing,
            t: hit.t,
            material,
            color: surface.color,
            offset_normal: off,
        };
        let ambient = match &scene.environment {
            None => surface.ambient(),
            Some(env) => surface.ambient_under(env, facing),
        };
        let ambient = if coverage < 1.0 {
            ambient * coverage
        } else {
            ambient
        };
        (sp, ambient, coverage)
    }

    /// `shade_from_donors` for one eye ray (from `origin` along `dir`, its
    /// hit `hit`) that takes every light's transmittance (`through`, none
    /// `TRACE_LIGHT`) and its secondary colour: its own ambient, diffuse and
    /// highlight terms, with no ray traced and no packet to fill, the same
    /// colour bit for bit.
    pub fn shade_taking(
        &self,
        origin: Vec3,
        dir: Vec3,
        (prim, hit): (u32, SurfaceHit),
        through: &[f32],
        secondary: Color,
    ) -> Color {
        // At the deepest level: no secondary ray is spawned (the donor's are taken).
        let (sp, mut out, coverage) = self.surface_point(origin, dir, prim as usize, &hit, false);
        if sp.material.kd > 0.0 || sp.material.ks > 0.0 {
            for (light, &t) in self.world.scene.lights.iter().zip(through) {
                if t > 0.0 {
                    if let Some((l, _, color)) = toward_light(&sp, light) {
                        out += light_contribution(&sp, dir, l, color, t * coverage);
                    }
                }
            }
        }
        out + secondary
    }

    /// Stage 2: diffuse and highlight from every light not in shadow. The lanes'
    /// shadow rays toward a light go as one packet. With `record`, each lane's
    /// transmittance toward each light is written there (lane `l`'s light `i`
    /// at `l * lights + i`; left 0 where no shadow ray was cast), for the
    /// reprojection of its shading to other views.
    fn direct_light<const K: usize>(
        &mut self,
        packet: &Packet<K>,
        s: &Surfaces<'a, K>,
        out: &mut [Color; K],
        mut record: Option<&mut [f32]>,
        level: u32,
    ) {
        if s.lit == 0 {
            return;
        }
        let world = self.world;
        let scene = &world.scene;
        // Every light's shadow segment of a lane starts at one point.
        let origins: [Vec3; K] = std::array::from_fn(|l| match &s.points[l] {
            Some(sp) if s.lit & (1 << l) != 0 => offset_point(sp.point, sp.offset_normal, sp.t),
            _ => Vec3::ZERO,
        });
        for (i, light) in scene.lights.iter().enumerate() {
            let mut seg = SegmentPacket::<K>::empty();
            let mut light_color = [Color::ZERO; K];
            let mut lanes = s.lit;
            while lanes != 0 {
                let l = lanes.trailing_zeros() as usize;
                lanes &= lanes - 1;
                let Some(sp) = &s.points[l] else { continue };
                if let Some((dir, dist, color)) = toward_light(sp, light) {
                    light_color[l] = color;
                    seg.origins[l] = origins[l];
                    seg.dirs[l] = dir;
                    seg.t_max[l] = dist;
                    seg.mask |= 1 << l;
                }
            }
            if seg.mask == 0 {
                continue;
            }
            let through = self.light_transmittance(i, level, &mut seg);
            if let Some(r) = record.as_deref_mut() {
                let lights = scene.lights.len();
                let mut lanes = seg.mask;
                while lanes != 0 {
                    let l = lanes.trailing_zeros() as usize;
                    lanes &= lanes - 1;
                    if let Some(slot) = r.get_mut(l * lights + i) {
                        *slot = through[l];
                    }
                }
            }
            let mut lanes = seg.mask;
            while lanes != 0 {
                let l = lanes.trailing_zeros() as usize;
                lanes &= lanes - 1;
                if let (Some(sp), true) = (&s.points[l], through[l] > 0.0) {
                    out[l] += light_contribution(
                        sp,
                        packet.dirs[l],
                        seg.dirs[l],
                        light_color[l],
                        through[l] * s.coverage[l],
                    );
                }
            }
        }
    }

    /// What of light `i` reaches the start of each lane's shadow segment:
    /// the shadow cache's opaque object first, then one packet traversal for
    /// the rest.
    #[inline(always)]
    fn light_transmittance<const K: usize>(
        &mut self,
        i: usize,
        level: u32,
        seg: &mut SegmentPacket<K>,
    ) -> [f32; K] {
        let world = self.world;
        let with_shadow_ray = seg.mask;
        self.counts.rays.shadow += seg.mask.count_ones() as u64;
        let mut through = [1.0f32; K];
        let slots = self.cache_slot(level, i);
        let mut lanes = seg.mask;
        while lanes != 0 {
            let l = lanes.trailing_zeros() as usize;
            lanes &= lanes - 1;
            let cached = self.shadow_cache.get(slots + l).copied().flatten();
            if let Some(prim) = cached {
                self.counts.shadow_cache_tests += 1;
                // Trusted only where the traversal would find it too: it tests a
                // primitive only if the segment enters its box, and a primitive's
                // test can report a hit outside its box where its arithmetic
                // breaks down (a cone seen from 1e8 away). The traversal's
                // answer must not depend on what the cache holds.
                let (o, d, t) = (seg.origins[l], seg.dirs[l], seg.t_max[l]);
                // The boxes first: cheaper than a sphere's or a cone's test,
                // and most stale blockers' boxes are missed (both must hold).
                if world.filed_boxes(prim).any(|b| segment_enters(&b, o, d, t))
                    && blocks(world, prim, o, d, t)
                {
                    through[l] = 0.0;
                    self.counts.shadow_cache_hits += 1;
                    seg.mask &= !(1 << l);
                }
            }
        }
        let traced = seg.mask;
        if traced != 0 {
            let (found, blocker) = shadow_packet(world, seg, &mut self.traversal);
            let mut lanes = traced;
            while lanes != 0 {
                let l = lanes.trailing_zeros() as usize;
                lanes &= lanes - 1;
                through[l] = found[l];
                if let Some(slot) = self.shadow_cache.get_mut(slots + l) {
                    *slot = blocker[l];
                }
            }
        }
        seg.mask = with_shadow_ray;
        through
    }

    /// The shadow cache's slot of lane 0 toward light `i` from a hit of ray
    /// level `level` (levels past `CACHED_LEVELS` share the last).
    #[inline]
    fn cache_slot(&self, level: u32, i: usize) -> usize {
        let level = (level.max(1) as usize).min(CACHED_LEVELS) - 1;
        (level * self.world.scene.lights.len() + i) * MAX_LANES
    }

    /// Stage 3: the reflected, then the refracted rays, each kind as one packet,
    /// weighted into the lanes' colours. With `record`, each lane's sum of
    /// weighted secondary colours is written there.
    fn secondary<const K: usize>(
        &mut self,
        s: &Surfaces<'a, K>,
        level: u32,
        weights: &[f32; K],
        tree: &mut ShadingTree,
        out: &mut [Color; K],
        mut record: Option<&mut [Color]>,
    ) {
        // Rays passed straight through a BLEND surface count as refracted.
        for (spawns, reflected) in [
            (&s.reflected, true),
            (&s.refracted, false),
            (&s.passed, false),
        ] {
            if spawns.iter().all(Option::is_none) {
                continue;
            }
            let c = match tree.secondary {
                SecondaryRays::MergedOnPlanes => {
                    self.trace_spawned_merged(s, spawns, level + 1, weights, tree)
                }
                SecondaryRays::Own => self.trace_spawned(spawns, level + 1, weights, tree),
            };
            for l in 0..K {
                if let Some(sp) = spawns[l] {
                    if reflected {
                        self.counts.rays.reflected += 1;
                    } else {
                        self.counts.rays.refracted += 1;
                    }
                    let add = c[l] * sp.coefficient * sp.tint;
                    out[l] += add;
                    if let Some(r) = record.as_deref_mut().and_then(|r| r.get_mut(l)) {
                        *r += add;
                    }
                }
            }
        }
    }

    fn wanted(&self, weight: f32) -> bool {
        self.settings.spd || weight >= self.settings.min_weight
    }

    /// Traces every lane's spawned ray, all lanes as one packet: each lane's ray
    /// is its own (it sees only its view's world), the descent is shared.
    fn trace_spawned<const K: usize>(
        &mut self,
        spawns: &[Option<Spawn>; K],
        level: u32,
        weights: &[f32; K],
        tree: &mut ShadingTree,
    ) -> [Color; K] {
        let mut packet = Packet {
            origins: [Vec3::ZERO; K],
            dirs: [Vec3::Z; K],
            t_min: 0.0,
            t_max: [f32::INFINITY; K],
            mask: 0,
        };
        let mut child_weights = [0.0; K];
        for (l, s) in spawns.iter().enumerate() {
            if let Some(s) = s {
                packet.mask |= 1 << l;
                packet.origins[l] = s.origin;
                packet.dirs[l] = s.dir;
                child_weights[l] = weights[l] * s.coefficient;
            }
        }
        let lanes = packet.mask.count_ones() as u64;
        if lanes == 0 {
            return [Color::ZERO; K];
        }
        if lanes > 1 {
            self.counts.shared_secondary += 1;
            self.counts.shared_secondary_rays += lanes;
        }
        if lanes == 1 && K > 1 {
            // One lane: trace it as a plain ray, with no idle lanes to carry.
            let l = packet.mask.trailing_zeros() as usize;
            let single = Packet {
                origins: [packet.origins[l]],
                dirs: [packet.dirs[l]],
                t_min: 0.0,
                t_max: [f32::INFINITY],
                mask: 1,
            };
            let mut out = [Color::ZERO; K];
            let above = tree.single;
            tree.single = tree.top_lanes::<K>(1 << l);
            out[l] = self.trace::<1>(&single, level, [child_weights[l]], tree)[0];
            tree.single = above;
            return out;
        }
        self.trace(&packet, level, child_weights, tree)
    }
}

/// A packet's rays against the scene's shapes (also the ground truth's
/// nearest-hit searches).
pub(crate) struct NearestShape<'a, const K: usize> {
    shapes: &'a [Shape],
    packet: &'a Packet<K>,
    /// The packet as eight rays, made at the first `test_lanes`.
    eight: Option<EightRays>,
}

impl<'a, const K: usize> NearestShape<'a, K> {
    pub(crate) fn new(shapes: &'a [Shape], packet: &'a Packet<K>) -> NearestShape<'a, K> {
        NearestShape {
            shapes,
            packet,
            eight: None,
        }
    }

    #[inline(always)]
    fn ray(&self, lane: usize) -> Ray {
        Ray::new(self.packet.origins[lane], self.packet.dirs[lane])
    }
}

impl<const K: usize> NearestTest for NearestShape<'_, K> {
    #[inline(always)]
    fn test(&mut self, prim: u32, lane: usize, t_max: f32) -> Option<SurfaceHit> {
        self.shapes[prim as usize].intersect(&self.ray(lane), self.packet.t_min, t_max)
    }

    /// Spheres and cones, for up to eight lanes at once (`Shape::intersect8`,
    /// each lane bit for bit the single test).
    #[inline(always)]
    fn test_lanes(&mut self, prim: u32, _lanes: u32, t_max: f32x8) -> Option<EightHits> {
        let shape = &self.shapes[prim as usize];
        if K > 8 || matches!(shape, Shape::Triangle(_)) {
            return None;
        }
        let rays = match self.eight {
            Some(rays) => rays,
            None => {
                let rays = EightRays::of_packet(K, |l| self.ray(l));
                self.eight = Some(rays);
                rays
            }
        };
        shape.intersect8(&rays, self.packet.t_min, t_max)
    }

    /// The leaves of triangles as SIMD blocks: one routine for every method.
    #[inline(always)]
    fn test_block(&mut self, block: &Triangle4, lane: usize, t_max: f32) -> Option<BlockHits> {
        Some(block.intersect(&self.ray(lane), self.packet.t_min, t_max))
    }

    #[inline(always)]
    fn test_two_blocks(
        &mut self,
        blocks: &[Triangle4; 2],
        lane: usize,
        t_max: f32,
    ) -> Option<[BlockHits; 2]> {
        let ray = self.ray(lane);
        Some(Triangle4::intersect_two(
            blocks,
            &ray,
            self.packet.t_min,
            t_max,
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rig::Camera;

    /// Mirrors (a floor and a wall parallel to the eyes, spheres), glass,
    /// opaque blockers, a cone, and six coloured lights.
    const SCENE: &str =
        "b 0.1 0.1 0.2\nv\nfrom 0 -8 2\nat 0 0 1\nup 0 0 1\nangle 45\nhither 0.01\n\
        resolution 64 48\n\
        l -5 -5 6 0.4 0.3 0.3\nl 5 -4 5 0.3 0.4 0.3\nl 0 -2 8 0.3 0.3 0.4\nl -3 3 3 0.3 0.3 0.3\n\
        l 4 2 1 0.2 0.3 0.2\nl 0 -7 1 0.2 0.2 0.3\n\
        f 0.8 0.8 0.7 0.6 0.3 20 0 1\np 4\n-6 -6 0\n6 -6 0\n6 6 0\n-6 6 0\n\
        f 0.9 0.9 0.9 0.1 0.8 100 0 1\np 4\n-6 5 0\n6 5 0\n6 5 5\n-6 5 5\n\
        f 0.9 0.2 0.2 0.7 0.2 30 0 1\ns -1.5 0 1 0.8\n\
        f 0.9 0.9 0.9 0.1 0.8 200 0 1\ns 1.5 1 1.2 1\n\
        f 0.9 0.95 1 0.05 0.1 200 0.8 1.5\ns 0 -2 0.8 0.7\n\
        f 0.2 0.8 0.3 0.8 0 10 0 1\ns -0.3 -4 1.6 0.3\ns 0.6 -3.5 0.5 0.25\n\
        f 0.3 0.4 0.9 0.7 0.2 30 0 1\nc\n2.5 -1.5 0 0.6\n2.5 -1.5 2 0.1\n";

    /// The camera's eye ray through the centre of pixel (`x`, `y`).
    pub(super) fn pixel_ray(camera: &Camera, x: u32, y: u32) -> Packet<1> {
        Packet {
            origins: [camera.eye],
            dirs: [camera.direction(x as f32, y as f32)],
            t_min: camera.hither,
            t_max: [f32::INFINITY],
            mask: 1,
        }
    }

    fn bits(c: Color) -> [u32; 3] {
        c.to_array().map(f32::to_bits)
    }

    /// `count` random packets of `K` eye rays: each lane an eye `offset`
    /// apart along the camera's right axis, through a pixel near the
    /// packet's (the views' rays of one sample, or of nearby samples).
    fn eye_packets<const K: usize>(
        camera: &Camera,
        rng: &mut fastrand::Rng,
        count: usize,
    ) -> Vec<Packet<K>> {
        (0..count)
            .map(|_| {
                let (x, y) = (
                    rng.f32() * camera.width as f32,
                    rng.f32() * camera.height as f32,
                );
                let spread = if rng.bool() { 0.0 } else { 3.0 };
                let all = if K == 32 { u32::MAX } else { (1u32 << K) - 1 };
                let mask = if rng.bool() {
                    all
                } else {
                    (rng.u32(..) & all).max(1)
                };
                Packet {
                    origins: std::array::from_fn(|l| camera.eye_at(l as f32 * 0.11 - 0.5)),
                    dirs: std::array::from_fn(|_| {
                        let dx = (rng.f32() - 0.5) * spread;
                        let dy = (rng.f32() - 0.5) * spread;
                        camera.direction(x + dx, y + dy)
                    }),
                    t_min: camera.hither,
                    t_max: [f32::INFINITY; K],
                    mask,
                }
            })
            .collect()
    }

    /// `eye_hit` (the inlined one-ray descent) gives what `eye_hits` gives,
    /// bit for bit, and counts the same work (traversal counters included),
    /// on rays through and around the scene of spheres, polygons and a cone.
    #[test]
    fn one_eye_ray_alone_is_what_a_packet_of_one_gives() {
        let world = World::from_nff_text(SCENE);
        let camera = Camera::new(&world.scene.viewpoint, 64, 48);
        let mut rng = fastrand::Rng::with_seed(17);
        let mut alone = Tracer::new(&world, TraceSettings::default());
        let mut packed = Tracer::new(&world, TraceSettings::default());
        assert!(alone.eye_hit_applies());
        let mut hit = 0;
        for (n, packet) in eye_packets::<1>(&camera, &mut rng, 3000).iter().enumerate() {
            let view = n % 3;
            let (prim, h) = alone.eye_hit(packet, view);
            let p = packed.eye_hits(packet, &[view]);
            assert_eq!(prim, p.prim[0], "ray {n}");
            let bits = |h: SurfaceHit| [h.t, h.u, h.v].map(f32::to_bits);
            assert_eq!(bits(h), bits(p.hit[0]), "ray {n}");
            hit += usize::from(p.has_hit(0));
        }
        assert!((500..2900).contains(&hit), "{hit} of 3000 rays hit");
        let (a, b) = (alone.finish(), packed.finish());
        assert_eq!(a.per_view_hits, b.per_view_hits);
        assert_eq!(a, b);
    }

    /// Eight eye rays in one descent (`eye_hits8`, the mono row's packets)
    /// give each lane, bit for bit, what `eye_hit` gives it alone, and count
    /// the same rays and hits, and one traversal a packet; a refused packet
    /// (its lanes' signs differ) counts nothing.
    #[test]
    fn eight_eye_rays_in_one_descent_are_eight_alone() {
        let world = World::from_nff_text(SCENE);
        let camera = Camera::new(&world.scene.viewpoint, 64, 48);
        let mut rng = fastrand::Rng::with_seed(23);
        let mut alone = Tracer::new(&world, TraceSettings::default());
        let mut packed = Tracer::new(&world, TraceSettings::default());
        assert!(packed.eye_hit_applies());
        let (mut in_packets, mut refused) = (0, 0);
        for (n, packet) in eye_packets::<8>(&camera, &mut rng, 1500).iter().enumerate() {
            let view = n % 3;
            let got = packed.eye_hits8(packet, &[view; 8]);
            refused += usize::from(got.is_none());
            for l in (0..8).filter(|&l| packet.mask & (1 << l) != 0) {
                let one = packet.lane(l);
                let (prim, h) = alone.eye_hit(&one, view);
                let Some(got) = got else {
                    packed.eye_hit(&one, view);
                    continue;
                };
                in_packets += 1;
                assert_eq!(prim, got.prim[l], "packet {n}, lane {l}");
                let bits = |h: SurfaceHit| [h.t, h.u, h.v].map(f32::to_bits);
                assert_eq!(bits(h), bits(got.hit[l]), "packet {n}, lane {l}");
            }
        }
        assert!(in_packets > 3000 && refused > 50, "{in_packets} {refused}");
        let (a, p) = (alone.finish(), packed.finish());
        assert_eq!(p.eye_packet_rays, in_packets as u64);
        assert_eq!(p.eye_packets as usize, 1500 - refused);
        assert_eq!(a.per_view_hits, p.per_view_hits);
        assert_eq!(a.rays, p.rays);
        let descents = p.eye_packets + (a.rays.eye - p.eye_packet_rays);
        assert_eq!(
            (p.closest_traversals, p.eye_traversals),
            (descents, descents)
        );
        assert_eq!(a.eye_traversals, a.rays.eye);
    }

    /// A packet of `K` lanes through one tracer (its shadow cache filled by
    /// the packets before) gives each lane, bit for bit, what the lane alone
    /// gives through another tracer, and traces the same rays.
    fn packets_equal_single_lanes<const K: usize>(world: &World, seed: u64, count: usize) {
        let camera = Camera::new(&world.scene.viewpoint, 64, 48);
        let mut rng = fastrand::Rng::with_seed(seed);
        let mut packed = Tracer::new(world, TraceSettings::default());
        let mut single = Tracer::new(world, TraceSettings::default());
        let views: [usize; K] = std::array::from_fn(|l| l);
        for (n, packet) in eye_packets::<K>(&camera, &mut rng, count)
            .iter()
            .enumerate()
        {
            let colors = packed.trace_eye(packet, &views);
            for (l, &lane_color) in colors.iter().enumerate() {
                if packet.mask & (1 << l) == 0 {
                    continue;
                }
                let alone = Packet {
                    origins: [packet.origins[l]],
                    dirs: [packet.dirs[l]],
                    t_min: packet.t_min,
                    t_max: [f32::INFINITY],
                    mask: 1,
                };
                let color = single.trace_eye(&alone, &[l]);
                assert_eq!(
                    bits(lane_color),
                    bits(color[0]),
                    "K={K}, packet {n}, lane {l}: {lane_color:?} vs {:?}",
                    color[0]
                );
            }
        }
        let (p, s) = (packed.finish(), single.finish());
        assert_eq!(p.rays, s.rays, "K={K}: the same rays");
        assert_eq!(p.per_view_hits, s.per_view_hits, "K={K}: hits per view");
        assert!(p.rays.shadow > 0 && p.rays.reflected > 0 && p.rays.refracted > 0);
        assert!(
            p.closest_traversals < s.closest_traversals,
            "K={K}: descents shared"
        );
    }

    #[test]
    fn a_packet_of_k_lanes_gives_what_k_single_lane_calls_give() {
        let w = World::from_nff_text(SCENE);
        packets_equal_single_lanes::<2>(&w, 1, 600);
        packets_equal_single_lanes::<4>(&w, 2, 300);
        packets_equal_single_lanes::<8>(&w, 3, 150);
        packets_equal_single_lanes::<32>(&w, 4, 40);
    }

    /// The shadow cache: per ray level, the blocker of the last traced
    /// segment. A shadowed segment sets it, the next segments near it take it
    /// without a traversal, a lit segment clears it (a stale blocker would be
    /// tested in vain), and a segment from another level leaves it alone.
    #[test]
    fn the_shadow_cache_keeps_the_last_blocker_of_each_ray_level() {
        let w = World::from_nff_text(
            "v\nfrom 0 0 10\nat 0 0 0\nup 0 1 0\nangle 45\nhither 0.01\nresolution 8 8\n\
             l 0 0 8\nf 1 1 1 1 0 1 0 1\np 4\n-5 -5 0\n5 -5 0\n5 5 0\n-5 5 0\n\
             s 0 0 2 0.5\n",
        );
        let sphere = w
            .scene
            .shapes
            .iter()
            .position(|s| matches!(s, Shape::Sphere(_)))
            .map(|i| i as u32);
        assert!(sphere.is_some());
        // From the floor at (x, 0) to the light: under the sphere for small x.
        let toward_light = |x: f32| {
            let origin = Vec3::new(x, 0.0, 1e-3);
            let to = Vec3::new(0.0, 0.0, 8.0) - origin;
            SegmentPacket {
                origins: [origin],
                dirs: [to.normalize()],
                t_max: [to.length()],
                mask: 1,
            }
        };
        let mut tracer = Tracer::new(&w, TraceSettings::default());
        // (x, level, transmittance, cache tests and hits after, level 1's slot after)
        let steps = [
            (0.0, 1, 0.0, 0, 0, sphere),
            (0.05, 1, 0.0, 1, 1, sphere),
            (3.0, 2, 1.0, 1, 1, sphere),
            (-0.05, 1, 0.0, 2, 2, sphere),
            (3.0, 1, 1.0, 3, 2, None),
            (-3.0, 1, 1.0, 3, 2, None),
        ];
        for (x, level, through, tests, hits, slot) in steps {
            let mut seg = toward_light(x);
            let found = tracer.light_transmittance(0, level, &mut seg);
            let c = &tracer.counts;
            let what = format!("x = {x}, level {level}");
            assert_eq!(found[0], through, "{what}");
            assert_eq!(
                (c.shadow_cache_tests, c.shadow_cache_hits),
                (tests, hits),
                "{what}"
            );
            assert_eq!(tracer.shadow_cache[tracer.cache_slot(1, 0)], slot, "{what}");
        }
        assert_eq!(tracer.shadow_cache[tracer.cache_slot(2, 0)], None);
    }

    #[test]
    fn with_the_shadow_cache_inside_a_huge_sphere_lanes_still_equal_single_calls() {
        // The fuzzer's mutant: a glass sphere 2e8 wide around everything,
        // whose wall's shadow rays pass cones that their test says they hit.
        let w = World::from_nff_text(include_str!(
            "../../../tests/data/fuzz/twin-differs-huge-sphere.nff"
        ));
        packets_equal_single_lanes::<2>(&w, 5, 800);
        packets_equal_single_lanes::<4>(&w, 6, 400);
    }

    #[test]
    fn a_donor_keeps_its_colour_and_its_trees_largest_coefficient() {
        let w = World::from_nff_text(SCENE);
        let camera = Camera::new(&w.scene.viewpoint, 64, 48);
        let mut tracer = Tracer::new(&w, TraceSettings::default());
        let mut donor = Donor::default();
        let (mut mirrors, mut diffuse) = (0, 0);
        for y in 0..48 {
            for x in 0..64 {
                let packet = pixel_ray(&camera, x, y);
                let hits = tracer.eye_hits(&packet, &[0]);
                let traced = tracer.shade_eye(&packet, &hits, SecondaryRays::Own)[0];
                tracer.shade_donor(&packet, &hits, SecondaryRays::Own, &mut donor);
                assert_eq!(bits(donor.color), bits(traced), "pixel ({x}, {y})");
                if !hits.has_hit(0) {
                    continue;
                }
                let m = w.material_of(hits.prim[0]);
                let own = m.ks.max(m.mirror).max(m.t);
                // The tree holds at least the surface hit; a surface that spawns
                // nothing holds only its own.
                assert!(donor.tree_coefficient >= own);
                if m.mirror == 0.0 && m.t == 0.0 {
                    diffuse += 1;
                    assert_eq!(donor.tree_coefficient, own, "pixel ({x}, {y})");
                } else if donor.tree_coefficient > own {
                    mirrors += 1;
                }
            }
        }
        assert!(
            diffuse > 0 && mirrors > 0,
            "{diffuse} diffuse, {mirrors} deeper trees"
        );
    }

    /// `shade_donors` keeps, for each lane of a packet of eight, what
    /// `shade_donor` keeps for that lane alone (colour, transmittance toward
    /// each light, secondary colour, its tree's largest coefficient), bit for
    /// bit, with the lanes' own or merged secondary rays (a packet of donors
    /// merges no two lanes' rays, as a one-lane tree merges nothing); and
    /// `shade_from_donors` gives each lane, taking another lane's donor,
    /// what `shade_from_donor` gives it alone.
    #[test]
    fn a_packet_of_donors_keeps_what_each_donor_keeps_alone() {
        let w = World::from_nff_text(SCENE);
        let camera = Camera::new(&w.scene.viewpoint, 64, 48);
        let lights = w.scene.lights.len();
        let mut rng = fastrand::Rng::with_seed(11);
        for secondary in [SecondaryRays::Own, SecondaryRays::MergedOnPlanes] {
            let mut packed = Tracer::new(&w, TraceSettings::default());
            let mut single = Tracer::new(&w, TraceSettings::default());
            let (mut donors, mut donor) = (Donors::default(), Donor::default());
            let (mut shadowed, mut deeper, mut lanes) = (0, 0, 0);
            for (n, packet) in eye_packets::<EYE_PACKET>(&camera, &mut rng, 200)
                .iter()
                .enumerate()
            {
                let hits = packed.eye_hits(packet, &[0; EYE_PACKET]);
                packed.shade_donors(packet, &hits, secondary, &mut donors);
                let alone = |l: usize| {
                    let ray = Packet {
                        origins: [packet.origins[l]],
                        dirs: [packet.dirs[l]],
                        t_min: packet.t_min,
                        t_max: [f32::INFINITY],
                        mask: 1,
                    };
                    let hit = PacketHits {
                        prim: [hits.prim[l]],
                        hit: [hits.hit[l]],
                    };
                    (ray, hit)
                };
                let used: Vec<usize> = (0..EYE_PACKET)
                    .filter(|l| packet.mask & (1 << l) != 0)
                    .collect();
                for &l in &used {
                    let (ray, hit) = alone(l);
                    single.shade_donor(&ray, &hit, secondary, &mut donor);
                    let what = format!("{secondary:?}, packet {n}, lane {l}");
                    assert_eq!(bits(donors.colors[l]), bits(donor.color), "{what}");
                    let through = |t: &[f32]| t.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                    assert_eq!(
                        through(donors.through(l, lights)),
                        through(&donor.through),
                        "{what}"
                    );
                    assert_eq!(bits(donors.secondary[l]), bits(donor.secondary), "{what}");
                    assert_eq!(
                        donors.tree_coefficients[l].to_bits(),
                        donor.tree_coefficient.to_bits(),
                        "{what}"
                    );
                    lanes += 1;
                    shadowed += usize::from(donor.through.contains(&0.0) && hit.has_hit(0));
                    deeper += usize::from(donor.secondary != Color::ZERO);
                }
                // Each lane takes the next used lane's donor.
                let from = |k: usize| used[(k + 1) % used.len()];
                let mut through = vec![0.0; lights * EYE_PACKET];
                let mut taken = [Color::ZERO; EYE_PACKET];
                for (k, &l) in used.iter().enumerate() {
                    through[l * lights..(l + 1) * lights]
                        .copy_from_slice(donors.through(from(k), lights));
                    taken[l] = donors.secondary[from(k)];
                }
                let colors = packed.shade_from_donors(packet, &hits, &mut through, &taken);
                // Each lane with its own light, half of its lights marked to be
                // traced, and its own secondary colour: the shadow rays traced
                // find what the exact shading found, and the colour is the
                // exact one (bit for bit where no secondary light is added).
                let mut own = donors.through.clone();
                for (slot, t) in own.iter_mut().enumerate() {
                    if (slot + n) % 2 == 0 {
                        *t = TRACE_LIGHT;
                    }
                }
                let mine = packed.shade_from_donors(packet, &hits, &mut own, &donors.secondary);
                for &l in &used {
                    let what = format!("{secondary:?}, packet {n}, lane {l}, own light");
                    let found = own[l * lights..(l + 1) * lights]
                        .iter()
                        .map(|t| t.to_bits());
                    let exact = donors.through(l, lights).iter().map(|t| t.to_bits());
                    assert!(found.eq(exact), "{what}");
                    if donors.secondary[l] == Color::ZERO {
                        assert_eq!(bits(mine[l]), bits(donors.colors[l]), "{what}");
                    } else {
                        let d = (mine[l] - donors.colors[l]).abs();
                        assert!(d.max_element() < 1e-5, "{what}");
                    }
                }
                for (k, &l) in used.iter().enumerate() {
                    let (ray, hit) = alone(l);
                    let mut through = donors.through(from(k), lights).to_vec();
                    let secondary = [donors.secondary[from(k)]];
                    let color = single.shade_from_donors(&ray, &hit, &mut through, &secondary)[0];
                    assert_eq!(bits(colors[l]), bits(color), "{secondary:?}, {n}, {l}");
                }
            }
            assert!(
                shadowed > 20 && deeper > 20 && lanes > 800,
                "{shadowed} shadowed, {deeper} with secondary rays, of {lanes}"
            );
        }
    }

    #[test]
    fn merged_secondary_rays_are_taken_only_when_asked() {
        // Two views' rays onto the mirror floor: merged on request (approximate,
        // counted), their own rays otherwise (what each lane alone gives).
        let w = World::from_nff_text(SCENE);
        let camera = Camera::new(&w.scene.viewpoint, 64, 48);
        let mut tracer = Tracer::new(&w, TraceSettings::default());
        let (mut merged_differs, mut pairs) = (0, 0);
        for x in 0..64 {
            let packet = Packet {
                origins: [camera.eye_at(-0.2), camera.eye_at(0.2)],
                dirs: [camera.direction(x as f32, 44.0); 2],
                t_min: camera.hither,
                t_max: [f32::INFINITY; 2],
                mask: 0b11,
            };
            let hits = tracer.eye_hits(&packet, &[0, 1]);
            if !(hits.has_hit(0) && hits.has_hit(1)) {
                continue;
            }
            pairs += 1;
            let before = tracer.counts.paper.merged_rays;
            let own = tracer.shade_eye(&packet, &hits, SecondaryRays::Own);
            assert_eq!(tracer.counts.paper.merged_rays, before);
            let merged = tracer.shade_eye(&packet, &hits, SecondaryRays::MergedOnPlanes);
            if bits(merged[0]) != bits(own[0]) || bits(merged[1]) != bits(own[1]) {
                merged_differs += 1;
            }
        }
        assert!(pairs > 32, "{pairs}");
        assert!(tracer.counts.paper.merged_rays > 0);
        assert!(merged_differs > 0, "merging changed no colour");
    }
}

//! The Whitted tracer over packets of rays, one lane per view.
//!
//! A packet of one lane is an ordinary ray: the reference renders use that.
//! The twin method gives the tracer the views' samples of one surface point as
//! one packet (see `render`): their shadow rays toward each light go as one
//! packet, and their reflected (and refracted) rays too, recursively — each
//! lane's ray is its own view's, the descent of the hierarchy is shared. Each
//! lane's numbers are its own throughout, so every lane gets exactly what its
//! view's reference render gets.

use crate::bvh::{NearestTest, Packet, PacketHits, SegmentPacket, TraversalStats};
use crate::math::{reflect, refract, Color, Ray, Vec3};
use crate::scene::Material;
use crate::shading::{
    ambient, blocks, light_contribution, offset_point, shadow_packet, toward_light, SurfacePoint,
};
use crate::shapes::{Shape, SurfaceHit};
use crate::stats::TraceCounts;
use crate::world::World;

/// How deep and how far the tracer follows rays.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TraceSettings {
    /// Deepest ray level traced; the eye ray is level 1.
    pub max_depth: u32,
    /// Adaptive cut-off: a secondary ray is not traced when its weight in the
    /// pixel (product of the coefficients on its path) is below this. 0 = off.
    pub min_weight: f32,
    /// SPD testing procedure: every reflecting or transmitting hit spawns its
    /// reflected ray and every transmitting hit its refracted ray, whatever the weight.
    pub spd: bool,
}

impl Default for TraceSettings {
    fn default() -> Self {
        TraceSettings {
            max_depth: 5,
            min_weight: 1.0 / 256.0,
            spd: false,
        }
    }
}

pub struct Tracer<'a> {
    pub world: &'a World,
    pub settings: TraceSettings,
    pub counts: TraceCounts,
    traversal: TraversalStats,
    /// Per light and lane, the opaque primitive that last blocked a shadow ray
    /// toward the light (index `light * MAX_VIEWS + lane`).
    shadow_cache: Vec<Option<u32>>,
}

/// A secondary ray one lane wants traced, and its weight in the lane's colour.
#[derive(Clone, Copy)]
struct Spawn {
    origin: Vec3,
    dir: Vec3,
    coefficient: f32,
}

impl<'a> Tracer<'a> {
    pub fn new(world: &'a World, settings: TraceSettings) -> Tracer<'a> {
        Tracer {
            world,
            settings,
            counts: TraceCounts::default(),
            traversal: TraversalStats::default(),
            shadow_cache: vec![None; world.scene.lights.len() * super::MAX_VIEWS],
        }
    }

    /// The counters, with the hierarchy's work folded in.
    pub fn finish(mut self) -> TraceCounts {
        self.counts.add_traversal(&self.traversal);
        self.counts
    }

    /// Eye rays: lane `l` belongs to view `views[l]`.
    pub fn trace_eye<const K: usize>(
        &mut self,
        packet: &Packet<K>,
        views: &[usize; K],
    ) -> [Color; K] {
        let hits = self.eye_hits(packet, views);
        self.shade(packet, &hits, 1, [1.0; K])
    }

    /// The nearest hit of every lane of an eye-ray packet (one descent for all
    /// views); lane `l` belongs to view `views[l]`.
    pub fn eye_hits<const K: usize>(
        &mut self,
        packet: &Packet<K>,
        views: &[usize; K],
    ) -> PacketHits<K> {
        let hits = self.closest(packet);
        self.counts.eye_traversals += 1;
        let mut lanes = packet.mask;
        while lanes != 0 {
            let l = lanes.trailing_zeros() as usize;
            lanes &= lanes - 1;
            self.counts.rays.eye += 1;
            if hits.has_hit(l) {
                self.counts.rays.eye_hit += 1;
                if let Some(h) = self.counts.per_view_hits.get_mut(views[l]) {
                    *h += 1;
                }
            }
        }
        hits
    }

    /// Shades eye rays whose hits are known (`eye_hits`), the lanes together.
    pub fn shade_eye<const K: usize>(
        &mut self,
        packet: &Packet<K>,
        hits: &PacketHits<K>,
    ) -> [Color; K] {
        let lanes = packet.mask.count_ones() as u64;
        if lanes > 1 {
            self.counts.grouped_samples += lanes;
        }
        self.shade(packet, hits, 1, [1.0; K])
    }

    fn closest<const K: usize>(&mut self, packet: &Packet<K>) -> PacketHits<K> {
        self.counts.closest_traversals += 1;
        let test = NearestShape {
            shapes: &self.world.scene.shapes,
            packet,
        };
        self.world.bvh.closest(packet, &mut self.traversal, test)
    }

    /// Traces a secondary packet at `level`.
    fn trace<const K: usize>(
        &mut self,
        packet: &Packet<K>,
        level: u32,
        weights: [f32; K],
    ) -> [Color; K] {
        let hits = self.closest(packet);
        self.shade(packet, &hits, level, weights)
    }

    fn shade<const K: usize>(
        &mut self,
        packet: &Packet<K>,
        hits: &PacketHits<K>,
        level: u32,
        weights: [f32; K],
    ) -> [Color; K] {
        let world = self.world;
        let scene = &world.scene;
        let mut out = [scene.background; K];
        let mut reflected: [Option<Spawn>; K] = [None; K];
        let mut refracted: [Option<Spawn>; K] = [None; K];
        let spawn_more = level < self.settings.max_depth;
        let default_material = Material::default();
        let mut points: [SurfacePoint; K] = std::array::from_fn(|_| SurfacePoint {
            point: Vec3::ZERO,
            normal: Vec3::Z,
            t: 0.0,
            material: &default_material,
            color: Color::ZERO,
        });
        let mut lit = 0u32; // lanes with a hit whose material takes light
        let mut lanes = packet.mask;
        while lanes != 0 {
            let l = lanes.trailing_zeros() as usize;
            lanes &= lanes - 1;
            if !hits.has_hit(l) {
                continue;
            }
            let prim = hits.prim[l] as usize;
            let hit = &hits.hit[l];
            let d = packet.dirs[l];
            let shape = &scene.shapes[prim];
            let point = packet.origins[l] + d * hit.t;
            let surface = scene.surface_at(prim, hit, point);
            let (material, normal) = (surface.material, surface.normal);
            let facing = if normal.dot(d) < 0.0 { normal } else { -normal };
            points[l] = SurfacePoint {
                point,
                normal: facing,
                t: hit.t,
                material,
                color: surface.color,
            };
            out[l] = ambient(&points[l]);
            if material.kd > 0.0 || material.ks > 0.0 {
                lit |= 1 << l;
            }
            if !spawn_more {
                continue;
            }
            // Transmission first: total internal reflection hands its weight to the mirror.
            let mut mirror = material.mirror;
            if material.t > 0.0 {
                let entering = shape.geometric_normal(point).dot(d) < 0.0;
                let ior = if material.ior > 0.0 {
                    material.ior
                } else {
                    1.0
                };
                let eta = if entering { 1.0 / ior } else { ior };
                match refract(d, facing, eta) {
                    Some(dir) => {
                        if self.wanted(weights[l] * material.t) {
                            refracted[l] = Some(Spawn {
                                origin: offset_point(point, -facing, hit.t),
                                dir,
                                coefficient: material.t,
                            });
                        }
                    }
                    None => mirror += material.t,
                }
            }
            let spd_forces = self.settings.spd && (material.mirror > 0.0 || material.t > 0.0);
            if (mirror > 0.0 && self.wanted(weights[l] * mirror)) || spd_forces {
                reflected[l] = Some(Spawn {
                    origin: offset_point(point, facing, hit.t),
                    dir: reflect(d, facing),
                    coefficient: mirror,
                });
            }
        }
        // Direct light: the lanes' shadow rays toward each light go as one packet.
        if lit != 0 {
            for (i, light) in scene.lights.iter().enumerate() {
                let mut seg = SegmentPacket {
                    origins: [Vec3::ZERO; K],
                    dirs: [Vec3::Z; K],
                    t_max: [0.0; K],
                    mask: 0,
                };
                let mut light_color = [Color::ZERO; K];
                let mut lanes = lit;
                while lanes != 0 {
                    let l = lanes.trailing_zeros() as usize;
                    lanes &= lanes - 1;
                    if let Some((dir, dist, color)) = toward_light(&points[l], light) {
                        light_color[l] = color;
                        seg.origins[l] =
                            offset_point(points[l].point, points[l].normal, points[l].t);
                        seg.dirs[l] = dir;
                        seg.t_max[l] = dist;
                        seg.mask |= 1 << l;
                    }
                }
                if seg.mask == 0 {
                    continue;
                }
                self.counts.rays.shadow += seg.mask.count_ones() as u64;
                let with_shadow_ray = seg.mask;
                // Shadow cache: the opaque object that last shadowed this light is
                // tried first; lanes it blocks need no traversal.
                let mut through = [1.0f32; K];
                let mut lanes = seg.mask;
                while lanes != 0 {
                    let l = lanes.trailing_zeros() as usize;
                    lanes &= lanes - 1;
                    let cached = self
                        .shadow_cache
                        .get(i * super::MAX_VIEWS + l)
                        .copied()
                        .flatten();
                    if let Some(prim) = cached {
                        if blocks(world, prim, seg.origins[l], seg.dirs[l], seg.t_max[l]) {
                            through[l] = 0.0;
                            seg.mask &= !(1 << l);
                        }
                    }
                }
                let traced = seg.mask;
                let (found, blocker) = if traced == 0 {
                    ([1.0; K], [None; K])
                } else {
                    shadow_packet(world, &seg, &mut self.traversal)
                };
                let mut lanes = traced;
                while lanes != 0 {
                    let l = lanes.trailing_zeros() as usize;
                    lanes &= lanes - 1;
                    through[l] = found[l];
                    if let Some(b) = blocker[l] {
                        if let Some(slot) = self.shadow_cache.get_mut(i * super::MAX_VIEWS + l) {
                            *slot = Some(b);
                        }
                    }
                }
                let mut lanes = with_shadow_ray;
                while lanes != 0 {
                    let l = lanes.trailing_zeros() as usize;
                    lanes &= lanes - 1;
                    if through[l] > 0.0 {
                        out[l] += light_contribution(
                            &points[l],
                            packet.dirs[l],
                            seg.dirs[l],
                            light_color[l],
                            through[l],
                        );
                    }
                }
            }
        }
        if !spawn_more {
            return out;
        }
        for (spawns, count) in [(&reflected, 0), (&refracted, 1)] {
            if spawns.iter().all(Option::is_none) {
                continue;
            }
            let c = self.trace_spawned(spawns, level + 1, &weights);
            for l in 0..K {
                if let Some(s) = spawns[l] {
                    if count == 0 {
                        self.counts.rays.reflected += 1;
                    } else {
                        self.counts.rays.refracted += 1;
                    }
                    out[l] += c[l] * s.coefficient;
                }
            }
        }
        out
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
            out[l] = self.trace::<1>(&single, level, [child_weights[l]])[0];
            return out;
        }
        self.trace(&packet, level, child_weights)
    }
}

/// A packet's rays against the scene's shapes.
struct NearestShape<'a, const K: usize> {
    shapes: &'a [Shape],
    packet: &'a Packet<K>,
}

impl<const K: usize> NearestShape<'_, K> {
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

    #[inline(always)]
    fn test_pair(&mut self, prim: u32, t_max: [f32; 2]) -> [Option<SurfaceHit>; 2] {
        let rays = [self.ray(0), self.ray(1 % K)];
        self.shapes[prim as usize].intersect_pair(&rays, self.packet.t_min, t_max)
    }
}

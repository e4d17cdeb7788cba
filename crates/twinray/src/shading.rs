//! Whitted's local illumination, shared by every rendering method: ambient,
//! Lambert diffuse and Phong highlight for each point light not in shadow.
//!
//! The model (see docs/shading.md):
//!   I = ambient·C + Σ_lights S_l · I_l · (Kd·C·max(0, N·L) + Ks·max(0, R·V)^Shine)
//!       + Ks·I_reflected + T·I_transmitted
//! with `ambient = max(0, 1 − Kd − Ks − T)`, `N` the shading normal turned to
//! face the incoming ray, and `S_l` the light's transmittance: 0 behind an
//! opaque object, the product of `T` over the transmitting objects in between.
//! No shadow ray is cast where the normal faces away from the light.

use arrayvec::ArrayVec;

use crate::bvh::{AnyHit, AnyHitTest, SegmentPacket, TraversalStats};
use crate::lights::Light;
use crate::math::{Color, Ray, Vec3};
use crate::scene::Material;
use crate::world::World;

/// Distance a secondary ray's origin is moved off the surface, relative to the
/// magnitude of the coordinates involved (rounding of the hit point grows with it).
const OFFSET_RELATIVE: f32 = 2e-5;

/// `p` moved off the surface along `n` (unit) by a margin that covers the
/// rounding of a hit point computed at distance `t`.
#[inline]
pub fn offset_point(p: Vec3, n: Vec3, t: f32) -> Vec3 {
    let scale = p.abs().max_element() + t.abs();
    p + n * (OFFSET_RELATIVE * scale.max(1e-3))
}

/// What the tracer knows of a hit when it shades it.
#[derive(Clone, Copy, Debug)]
pub struct SurfacePoint<'a> {
    pub point: Vec3,
    /// Unit shading normal turned to face the incoming ray.
    pub normal: Vec3,
    /// Distance along the incoming ray (for the offset margin).
    pub t: f32,
    pub material: &'a Material,
    /// The surface colour here: the material's, times its texture.
    pub color: Color,
}

/// What reaches a point from a light through transmitting objects: the product
/// of their `T`, however many. The factors are multiplied in sorted order, so
/// the result does not depend on the order in which a traversal met the objects
/// (a packet of shadow rays may meet them in another order than a single ray).
/// The first 16 factors live inline; more spill to the heap (rare: light
/// through 17 glass objects).
#[derive(Clone, Debug, Default)]
pub struct Transmittance {
    inline: ArrayVec<f32, 16>,
    spilled: Vec<f32>,
    opaque: bool,
}

impl Transmittance {
    /// Records an object met on the way; `Stop` once nothing gets through.
    #[inline]
    pub fn meet(&mut self, t: f32) -> AnyHit {
        if t <= 0.0 {
            self.opaque = true;
            return AnyHit::Stop;
        }
        if let Err(full) = self.inline.try_push(t) {
            self.spilled.push(full.element());
        }
        AnyHit::Continue
    }

    pub fn value(&self) -> f32 {
        fn sorted_product(f: &mut [f32]) -> f32 {
            f.sort_unstable_by(f32::total_cmp);
            f.iter().product()
        }
        if self.opaque {
            0.0
        } else if self.spilled.is_empty() {
            sorted_product(&mut self.inline.clone())
        } else {
            sorted_product(&mut [&self.inline[..], &self.spilled[..]].concat())
        }
    }
}

/// The shadow rays of a packet of surface points toward one light, traced
/// together. Returns each lane's transmittance and, for lanes in full shadow,
/// the opaque primitive that blocked them (for the shadow cache).
pub fn shadow_packet<const K: usize>(
    world: &World,
    segments: &SegmentPacket<K>,
    stats: &mut TraversalStats,
) -> ([f32; K], [Option<u32>; K]) {
    let mut test = ShadowTest {
        world,
        segments,
        through: std::array::from_fn(|_| Transmittance::default()),
        blocker: [None; K],
    };
    world.bvh.occlusion(segments, stats, &mut test);
    let (mut through, mut blocker) = (test.through, test.blocker);
    if let Some(far) = &world.far {
        // Objects beyond the cut (section 2.3) shadow where they are; lanes
        // already in full shadow need not look further.
        let mut rest = *segments;
        for (l, t) in through.iter().enumerate() {
            if t.value() == 0.0 {
                rest.mask &= !(1 << l);
            }
        }
        let mut test = ShadowTest {
            world,
            segments: &rest,
            through,
            blocker,
        };
        far.occlusion(&rest, stats, &mut test);
        (through, blocker) = (test.through, test.blocker);
    }
    (std::array::from_fn(|l| through[l].value()), blocker)
}

/// What the shadow rays of a packet met so far.
struct ShadowTest<'a, const K: usize> {
    world: &'a World,
    segments: &'a SegmentPacket<K>,
    through: [Transmittance; K],
    blocker: [Option<u32>; K],
}

impl<const K: usize> ShadowTest<'_, K> {
    #[inline(always)]
    fn met(&mut self, prim: u32, lane: usize) -> AnyHit {
        let t = self.world.transmission_of(prim);
        if t <= 0.0 {
            self.blocker[lane] = Some(prim);
        }
        self.through[lane].meet(t)
    }

    #[inline(always)]
    fn ray(&self, lane: usize) -> Ray {
        Ray::new(self.segments.origins[lane], self.segments.dirs[lane])
    }
}

impl<const K: usize> AnyHitTest for ShadowTest<'_, K> {
    #[inline(always)]
    fn test(&mut self, prim: u32, lane: usize) -> AnyHit {
        let shape = &self.world.scene.shapes[prim as usize];
        if shape
            .intersect(&self.ray(lane), 0.0, self.segments.t_max[lane])
            .is_none()
        {
            return AnyHit::Continue;
        }
        self.met(prim, lane)
    }

    #[inline(always)]
    fn test_pair(&mut self, prim: u32) -> [AnyHit; 2] {
        let (a, b) = (0, 1 % K);
        let shape = &self.world.scene.shapes[prim as usize];
        let t_max = [self.segments.t_max[a], self.segments.t_max[b]];
        let found = shape.intersect_pair(&[self.ray(a), self.ray(b)], 0.0, t_max);
        [a, b].map(|l| {
            if found[l].is_none() {
                AnyHit::Continue
            } else {
                self.met(prim, l)
            }
        })
    }
}

/// Whether the opaque primitive `prim` blocks the segment: the shadow cache's
/// first guess. A yes is exact (any opaque object on the segment means full
/// shadow, whatever else is there); a no falls back to the full traversal.
#[inline]
pub fn blocks(world: &World, prim: u32, origin: Vec3, dir: Vec3, dist: f32) -> bool {
    world.scene.shapes[prim as usize]
        .intersect(&Ray::new(origin, dir), 0.0, dist)
        .is_some()
}

/// The direction, distance and colour of a light arriving at a surface point,
/// if the light is on the side the normal faces (else no shadow ray is cast).
#[inline]
pub fn toward_light(sp: &SurfacePoint, light: &Light) -> Option<(Vec3, f32, Color)> {
    let (l, dist, color) = light.toward(sp.point)?;
    (sp.normal.dot(l) > 0.0).then_some((l, dist, color))
}

/// Ambient term of the surface at `sp`, plus the light it emits.
#[inline]
pub fn ambient(sp: &SurfacePoint) -> Color {
    let a = sp.color * sp.material.ambient();
    if sp.material.emission == Color::ZERO {
        a
    } else {
        a + sp.material.emission
    }
}

/// Diffuse and Phong highlight from a light in direction `l` with colour
/// `light`, of which `through` reaches the point; `view_dir` is the incoming ray.
#[inline]
pub fn light_contribution(
    sp: &SurfacePoint,
    view_dir: Vec3,
    l: Vec3,
    light: Color,
    through: f32,
) -> Color {
    let m = sp.material;
    let mut c = sp.color * (m.kd * sp.normal.dot(l));
    if m.ks > 0.0 {
        let r = crate::math::reflect(-l, sp.normal);
        let r_dot_v = r.dot(-view_dir);
        if r_dot_v > 0.0 {
            c += m.specular_color * (m.ks * r_dot_v.powf(m.shine));
        }
    }
    c * light * through
}

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
use crate::scene::{AlphaMode, Material};
use crate::shapes::{BlockHits, EightRays, Shape, SurfaceHit, Triangle4};
use crate::world::World;
use wide::f32x8;

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
    /// The normal before a normal map bent it, turned like `normal`: shadow
    /// and secondary rays leave the surface along it.
    pub offset_normal: Vec3,
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

    #[inline]
    pub fn value(&self) -> f32 {
        fn sorted_product(f: &mut [f32]) -> f32 {
            f.sort_unstable_by(f32::total_cmp);
            f.iter().product()
        }
        // No factor, or one: the product needs no copy and no sort (1 · t is
        // t, bit for bit). These are the common cases: a lit segment, a
        // segment through one glass object.
        if self.opaque {
            0.0
        } else if self.inline.len() <= 1 {
            self.inline.first().copied().unwrap_or(1.0)
        } else if self.spilled.is_empty() {
            sorted_product(&mut self.inline.clone())
        } else {
            sorted_product(&mut [&self.inline[..], &self.spilled[..]].concat())
        }
    }
}

/// The shadow rays of a packet of surface points toward one light, traced
/// together. Returns each lane's transmittance and, for lanes in full shadow,
/// the opaque primitive that blocked them (for the shadow cache). In a scene
/// with cut-outs or partly transparent materials, each hit asks the alpha
/// where it is (only such scenes pay for it).
pub fn shadow_packet<const K: usize>(
    world: &World,
    segments: &SegmentPacket<K>,
    stats: &mut TraversalStats,
) -> ([f32; K], [Option<u32>; K]) {
    if world.has_alpha {
        shadow_packet_with::<K, true>(world, segments, stats)
    } else {
        shadow_packet_with::<K, false>(world, segments, stats)
    }
}

/// `shadow_packet`, asking the alpha at each hit (`ALPHA`) or not.
fn shadow_packet_with<const K: usize, const ALPHA: bool>(
    world: &World,
    segments: &SegmentPacket<K>,
    stats: &mut TraversalStats,
) -> ([f32; K], [Option<u32>; K]) {
    let mut test = ShadowTest::<K, ALPHA> {
        world,
        segments,
        through: std::array::from_fn(|_| Transmittance::default()),
        blocker: [None; K],
        eight: None,
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
        let mut test = ShadowTest::<K, ALPHA> {
            world,
            segments: &rest,
            through,
            blocker,
            eight: None,
        };
        far.occlusion(&rest, stats, &mut test);
        (through, blocker) = (test.through, test.blocker);
    }
    (std::array::from_fn(|l| through[l].value()), blocker)
}

/// What the shadow rays of a packet met so far; with `ALPHA`, a hit on a
/// MASK or BLEND material lets through what its alpha there says.
struct ShadowTest<'a, const K: usize, const ALPHA: bool> {
    world: &'a World,
    segments: &'a SegmentPacket<K>,
    through: [Transmittance; K],
    blocker: [Option<u32>; K],
    /// The segments as eight rays and their lengths, made at the first
    /// `test_lanes`.
    eight: Option<(EightRays, f32x8)>,
}

impl<const K: usize, const ALPHA: bool> ShadowTest<'_, K, ALPHA> {
    #[inline(always)]
    fn met(&mut self, prim: u32, lane: usize, hit: &SurfaceHit) -> AnyHit {
        if ALPHA && self.world.material_of(prim).alpha_mode != AlphaMode::Opaque {
            // Never a cached blocker: it blocks only where its alpha says so.
            return match self.world.scene.shadow_factor(prim as usize, hit) {
                None => AnyHit::Continue,
                Some(t) => self.through[lane].meet(t),
            };
        }
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

    /// A block's hits `b` on `prims` met in index order until one stops
    /// lane `lane`.
    #[inline(always)]
    fn met_block(&mut self, b: &BlockHits, prims: &[u32], lane: usize) -> AnyHit {
        for (i, hit) in b.first(prims.len()) {
            if self.met(prims[i], lane, &hit) == AnyHit::Stop {
                return AnyHit::Stop;
            }
        }
        AnyHit::Continue
    }
}

impl<const K: usize, const ALPHA: bool> AnyHitTest for ShadowTest<'_, K, ALPHA> {
    #[inline(always)]
    fn test(&mut self, prim: u32, lane: usize) -> AnyHit {
        let shape = &self.world.scene.shapes[prim as usize];
        match shape.intersect(&self.ray(lane), 0.0, self.segments.t_max[lane]) {
            None => AnyHit::Continue,
            Some(hit) => self.met(prim, lane, &hit),
        }
    }

    /// The leaves of triangles as SIMD blocks: hits met in index order, up
    /// to the first that stops the segment.
    #[inline(always)]
    fn test_block(&mut self, block: &Triangle4, prims: &[u32], lane: usize) -> Option<AnyHit> {
        let hits = block.intersect(&self.ray(lane), 0.0, self.segments.t_max[lane]);
        Some(self.met_block(&hits, prims, lane))
    }

    /// Spheres and cones, for up to eight lanes at once (`Shape::intersect8`,
    /// each lane bit for bit the single test).
    #[inline(always)]
    fn test_lanes(&mut self, prim: u32, lanes: u32) -> Option<u32> {
        if K > 8 {
            return None;
        }
        let shape = &self.world.scene.shapes[prim as usize];
        if matches!(shape, Shape::Triangle(_)) {
            return None;
        }
        let (rays, t_max) = match self.eight {
            Some(eight) => eight,
            None => {
                let t_max = std::array::from_fn(|l| self.segments.t_max[if l < K { l } else { 0 }]);
                let eight = (EightRays::of_packet(K, |l| self.ray(l)), f32x8::from(t_max));
                self.eight = Some(eight);
                eight
            }
        };
        let hits = shape.intersect8(&rays, 0.0, t_max)?;
        let mut met = hits.mask & lanes;
        let mut stopped = 0;
        while met != 0 {
            let l = met.trailing_zeros() as usize;
            met &= met - 1;
            if let Some(hit) = hits.hit(l) {
                if self.met(prim, l, &hit) == AnyHit::Stop {
                    stopped |= 1 << l;
                }
            }
        }
        Some(stopped)
    }

    #[inline(always)]
    fn test_block_pair(&mut self, block: &Triangle4, prims: &[u32]) -> Option<[AnyHit; 2]> {
        let (a, b) = (0, 1 % K);
        let t_max = [self.segments.t_max[a], self.segments.t_max[b]];
        let hits = block.intersect_pair(&[self.ray(a), self.ray(b)], 0.0, t_max);
        Some([a, b].map(|l| self.met_block(&hits[l], prims, l)))
    }

    #[inline(always)]
    fn test_pair(&mut self, prim: u32) -> [AnyHit; 2] {
        let (a, b) = (0, 1 % K);
        let shape = &self.world.scene.shapes[prim as usize];
        let t_max = [self.segments.t_max[a], self.segments.t_max[b]];
        let found = shape.intersect_pair(&[self.ray(a), self.ray(b)], 0.0, t_max);
        [a, b].map(|l| match &found[l] {
            None => AnyHit::Continue,
            Some(hit) => self.met(prim, l, hit),
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
/// Inlined with `Light::toward`: see there.
#[inline(always)]
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::loaders::nff::parse_nff;
    use crate::loaders::LoadOptions;

    fn point<'a>(material: &'a Material, normal: Vec3) -> SurfacePoint<'a> {
        SurfacePoint {
            point: Vec3::new(1.0, 2.0, 0.0),
            normal,
            t: 3.0,
            material,
            color: Color::new(0.5, 0.25, 1.0),
            offset_normal: normal,
        }
    }

    #[test]
    fn transmittance_is_the_same_in_any_order_past_sixteen_factors() {
        let mut rng = fastrand::Rng::with_seed(9);
        let mut factors: Vec<f32> = (0..23).map(|_| 0.3 + 0.7 * rng.f32()).collect();
        let product = |f: &[f32]| {
            let mut t = Transmittance::default();
            for &x in f {
                assert_eq!(t.meet(x), AnyHit::Continue);
            }
            t.value()
        };
        let first = product(&factors);
        for _ in 0..20 {
            rng.shuffle(&mut factors);
            assert_eq!(product(&factors).to_bits(), first.to_bits());
        }
        // All 23 factors count, not only the 16 kept inline.
        let mut sorted = factors.clone();
        sorted.sort_unstable_by(f32::total_cmp);
        assert_eq!(first.to_bits(), sorted.iter().product::<f32>().to_bits());
        assert!(first < product(&factors[..16]));
        // An opaque object stops the ray: nothing gets through.
        let mut t = Transmittance::default();
        t.meet(0.5);
        assert_eq!(t.meet(0.0), AnyHit::Stop);
        assert_eq!(t.value(), 0.0);
        assert_eq!(Transmittance::default().value(), 1.0);
        // One factor, or two, in either order: the value is their product.
        let mut one = Transmittance::default();
        one.meet(0.37);
        assert_eq!(one.value().to_bits(), 0.37f32.to_bits());
        for pair in [[0.3f32, 0.7], [0.7, 0.3]] {
            let mut two = Transmittance::default();
            for t in pair {
                assert_eq!(two.meet(t), AnyHit::Continue);
            }
            assert_eq!(two.value().to_bits(), (0.3f32 * 0.7).to_bits());
        }
    }

    #[test]
    fn a_moved_origin_leaves_the_surface_by_a_margin_that_grows_with_the_coordinates() {
        let n = Vec3::Z;
        let near = offset_point(Vec3::new(0.5, 0.5, 0.0), n, 1.0);
        let far = offset_point(Vec3::new(5e4, 0.5, 0.0), n, 1.0);
        assert!(near.z > 0.0 && far.z > near.z * 1000.0);
        assert_eq!((near.x, near.y), (0.5, 0.5), "moved along the normal only");
        // At the origin, a floor of 1e-3 on the scale still moves it.
        assert!(offset_point(Vec3::ZERO, n, 0.0).z > 0.0);
    }

    #[test]
    fn no_shadow_ray_toward_a_light_behind_the_surface() {
        let m = Material::default();
        let sp = point(&m, Vec3::Z);
        let above = Light::point(Vec3::new(1.0, 2.0, 10.0), None);
        let below = Light::point(Vec3::new(1.0, 2.0, -10.0), None);
        let (dir, dist, _) = toward_light(&sp, &above).expect("lit side");
        assert!((dir - Vec3::Z).length() < 1e-6 && (dist - 10.0).abs() < 1e-5);
        assert!(toward_light(&sp, &below).is_none());
    }

    #[test]
    fn ambient_diffuse_and_highlight_follow_the_model() {
        let m = Material {
            kd: 0.5,
            ks: 0.2,
            t: 0.1,
            shine: 10.0,
            emission: Color::new(0.0, 0.1, 0.0),
            ..Material::default()
        };
        let sp = point(&m, Vec3::Z);
        // ambient = max(0, 1 - Kd - Ks - T) = 0.2, times the colour, plus emission.
        let a = ambient(&sp);
        assert!((a - (sp.color * 0.2 + m.emission)).abs().max_element() < 1e-6);
        // A light at 60 degrees, seen along the mirror direction: Lambert and a
        // full highlight; half of it gets through.
        let l = Vec3::new(3f32.sqrt() / 2.0, 0.0, 0.5);
        let view_dir = -crate::math::reflect(-l, sp.normal);
        let light = Color::new(1.0, 0.5, 1.0);
        let c = light_contribution(&sp, view_dir, l, light, 0.5);
        let expect = (sp.color * (0.5 * 0.5) + Color::splat(0.2)) * light * 0.5;
        assert!((c - expect).abs().max_element() < 1e-5, "{c} vs {expect}");
        // Seen from elsewhere, the highlight fades (Shine 10).
        let aside = light_contribution(&sp, Vec3::new(0.0, 0.6, -0.8), l, light, 0.5);
        assert!(aside.x < c.x && aside.x >= (sp.color * 0.25 * light * 0.5).x);
    }

    /// Two glass spheres and an opaque one on the x axis, a light beyond them.
    const ROW: &str = "b 0 0 0\nv\nfrom 0 -10 0\nat 0 0 0\nup 0 0 1\nangle 30\nhither 0.01\n\
        resolution 8 8\nl 20 0 0\n\
        f 1 1 1 0 0 1 0.5 1\ns 2 0 0 0.5\n\
        f 1 1 1 0 0 1 0.8 1\ns 4 0 0 0.5\n\
        f 1 1 1 1 0 1 0 1\ns 6 0 3 0.5\n";

    #[test]
    fn shadow_packets_multiply_the_glass_and_name_the_opaque_blocker() {
        let w = World::from_nff_text(ROW);
        let opaque = (0..w.scene.shapes.len() as u32)
            .find(|&p| w.transmission_of(p) == 0.0)
            .expect("the opaque sphere");
        // Lane 0 through both glass spheres; lane 1 into the opaque one;
        // lane 2 stops short of everything; lane 3 masked off.
        let (o, up) = (Vec3::ZERO, Vec3::new(6.0, 0.0, 3.0));
        let segments = SegmentPacket {
            origins: [o, o, o, o],
            dirs: [Vec3::X, up.normalize(), Vec3::X, Vec3::X],
            t_max: [10.0, 20.0, 1.0, 10.0],
            mask: 0b0111,
        };
        let mut stats = TraversalStats::default();
        let (through, blocker) = shadow_packet(&w, &segments, &mut stats);
        assert_eq!(through[0].to_bits(), (0.5f32 * 0.8).to_bits());
        assert_eq!((through[1], blocker[1]), (0.0, Some(opaque)));
        assert_eq!((through[2], blocker[2]), (1.0, None));
        assert_eq!(blocker[0], None, "glass is no blocker for the cache");
        // Each lane alone gets the same.
        for l in 0..3 {
            let alone = SegmentPacket {
                origins: [segments.origins[l]],
                dirs: [segments.dirs[l]],
                t_max: [segments.t_max[l]],
                mask: 1,
            };
            let (t, b) = shadow_packet(&w, &alone, &mut stats);
            assert_eq!((t[0].to_bits(), b[0]), (through[l].to_bits(), blocker[l]));
        }
        assert!(blocks(&w, opaque, o, up.normalize(), 20.0));
        assert!(!blocks(&w, opaque, o, up.normalize(), 5.0), "short of it");
        assert!(!blocks(&w, opaque, o, Vec3::X, 20.0), "beside it");
    }

    #[test]
    fn objects_beyond_a_cut_still_cast_shadows() {
        // A cut at depth 5 in front of the camera (at y = -10) puts every
        // sphere (depth 10) beyond it, in the far hierarchy: the shadows are
        // the same as without the cut (section 2.3 cuts eye rays only).
        let whole = World::from_nff_text(ROW);
        let scene =
            parse_nff(ROW, std::path::Path::new("t.nff"), &LoadOptions::default()).expect("scene");
        let cut = crate::world::Cut {
            eye: Vec3::new(0.0, -10.0, 0.0),
            forward: Vec3::Y,
            depth: 5.0,
        };
        let split = World::with_cut(scene, Some(cut));
        assert!(split.far.is_some() && split.cut_primitives() == 3);
        let segments = SegmentPacket {
            origins: [Vec3::ZERO; 2],
            dirs: [Vec3::X, Vec3::new(6.0, 0.0, 3.0).normalize()],
            t_max: [10.0, 20.0],
            mask: 0b11,
        };
        let mut stats = TraversalStats::default();
        let (a, _) = shadow_packet(&whole, &segments, &mut stats);
        let (b, _) = shadow_packet(&split, &segments, &mut stats);
        assert_eq!(a.map(f32::to_bits), b.map(f32::to_bits));
        assert_eq!(b[1], 0.0);
    }
}

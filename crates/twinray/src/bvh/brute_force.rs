//! The reference the traversals are tested against: every primitive tested,
//! no hierarchy. Any hierarchy over the same shapes (the binary one, or a
//! wider one) must give, lane by lane, what these give on any ray — the same
//! nearest primitive and the same hit bits, ties to the lower index — and its
//! any-hit traversal must meet every primitive these find on a segment.
//!
//! With random shapes of every kind ([`random_shapes`]) and random packets
//! ([`random_packet`]): rays from near and far, in every direction, lanes
//! with their own origins, directions and `t_max`, some lanes masked off.

use super::{AnyHit, Packet, PacketHits, SegmentPacket};
use crate::math::{Ray, Vec3};
use crate::shapes::{Cone, Shape, Sphere, SurfaceHit, Triangle, TriangleNormals};

/// The nearest hit of lane `lane` of `packet` among all `shapes` (`t_min <
/// t < t_max[lane]`), ties to the lower index; `None` for a masked lane.
pub fn closest<const K: usize>(
    shapes: &[Shape],
    packet: &Packet<K>,
    lane: usize,
) -> Option<(u32, SurfaceHit)> {
    if packet.mask & (1 << lane) == 0 {
        return None;
    }
    let ray = Ray::new(packet.origins[lane], packet.dirs[lane]);
    let mut best: Option<(u32, SurfaceHit)> = None;
    for (i, shape) in shapes.iter().enumerate() {
        if let Some(h) = shape.intersect(&ray, packet.t_min, packet.t_max[lane]) {
            if best.is_none_or(|(_, b)| h.t < b.t) {
                best = Some((i as u32, h));
            }
        }
    }
    best
}

/// Every lane's [`closest`] hit, as a traversal reports it.
pub fn closest_hits<const K: usize>(shapes: &[Shape], packet: &Packet<K>) -> PacketHits<K> {
    let mut out = PacketHits {
        prim: [PacketHits::<K>::NO_HIT; K],
        hit: [SurfaceHit {
            t: f32::INFINITY,
            u: 0.0,
            v: 0.0,
        }; K],
    };
    for l in 0..K {
        if let Some((prim, hit)) = closest(shapes, packet, l) {
            (out.prim[l], out.hit[l]) = (prim, hit);
        }
    }
    out
}

/// The primitives lane `lane`'s segment (`0 < t < t_max[lane]`) meets, in
/// index order; empty for a masked lane.
pub fn occluders<const K: usize>(
    shapes: &[Shape],
    segments: &SegmentPacket<K>,
    lane: usize,
) -> Vec<u32> {
    if segments.mask & (1 << lane) == 0 {
        return Vec::new();
    }
    let ray = Ray::new(segments.origins[lane], segments.dirs[lane]);
    (0..shapes.len() as u32)
        .filter(|&p| {
            shapes[p as usize]
                .intersect(&ray, 0.0, segments.t_max[lane])
                .is_some()
        })
        .collect()
}

/// What each lane of `segments` meets (sorted; with `stop`, a lane stops at
/// the first primitive it meets), as an any-hit traversal that `descend`
/// runs with the test it is given reports it.
pub fn met<const K: usize>(
    shapes: &[Shape],
    segments: &SegmentPacket<K>,
    stop: bool,
    descend: impl FnOnce(&mut dyn FnMut(u32, usize) -> AnyHit),
) -> [Vec<u32>; K] {
    let mut met: [Vec<u32>; K] = std::array::from_fn(|_| Vec::new());
    descend(&mut |p: u32, l: usize| {
        let ray = Ray::new(segments.origins[l], segments.dirs[l]);
        if shapes[p as usize]
            .intersect(&ray, 0.0, segments.t_max[l])
            .is_some()
        {
            met[l].push(p);
            if stop {
                return AnyHit::Stop;
            }
        }
        AnyHit::Continue
    });
    met.map(|mut m| {
        m.sort_unstable();
        m
    })
}

fn random_point(rng: &mut fastrand::Rng, scale: f32) -> Vec3 {
    Vec3::new(rng.f32() - 0.5, rng.f32() - 0.5, rng.f32() - 0.5) * (2.0 * scale)
}

fn random_unit(rng: &mut fastrand::Rng) -> Vec3 {
    loop {
        let v = random_point(rng, 1.0);
        if (0.01..=1.0).contains(&v.length_squared()) {
            return v.normalize();
        }
    }
}

/// About `count` shapes of every kind in a cube of half-side 10: a floor
/// with spheres resting on it, spheres (some inside-out), triangles (some large, some slivers, some in one plane
/// with others, some in stacks a hair apart), cones and cylinders (some
/// inside-out).
pub fn random_shapes(rng: &mut fastrand::Rng, count: usize) -> Vec<Shape> {
    let mut shapes = Vec::with_capacity(count);
    // A floor at z = -2, and small spheres resting on it (below): where a
    // sphere meets the floor, a ray enters the sphere's box a hair before
    // it hits the floor, whichever the traversal visits first.
    let floor = [
        Vec3::new(-12.0, -12.0, -2.0),
        Vec3::new(12.0, -12.0, -2.0),
        Vec3::new(12.0, 12.0, -2.0),
        Vec3::new(-12.0, 12.0, -2.0),
    ];
    for [a, b, c] in [[0, 1, 2], [0, 2, 3]] {
        let (a, b, c) = (floor[a], floor[b], floor[c]);
        shapes.push(Shape::Triangle(Triangle::new(
            a,
            b,
            c,
            Vec3::Z,
            TriangleNormals::Flat,
        )));
    }
    while shapes.len() < count {
        if rng.u8(..6) == 0 {
            let radius = 0.1 + rng.f32() * 0.5;
            let at = random_point(rng, 10.0);
            shapes.push(Shape::Sphere(Sphere {
                center: Vec3::new(at.x, at.y, -2.0 + radius),
                radius,
                inside: false,
            }));
            continue;
        }
        let at = random_point(rng, 10.0);
        let size = 0.1 + rng.f32() * if rng.u8(..10) == 0 { 8.0 } else { 1.5 };
        if rng.u8(..12) == 0 {
            // A stack of parallel triangles a hair apart: boxes entered within
            // a fraction of a per cent of each other's hits (the culling slack).
            let (e1, e2) = (random_point(rng, size), random_point(rng, size));
            let n = e1.cross(e2).normalize_or_zero();
            if n != Vec3::ZERO {
                for k in 0..5 {
                    let a = at + n * (k as f32 * 0.01 * size);
                    shapes.push(Shape::Triangle(Triangle::new(
                        a,
                        a + e1,
                        a + e2,
                        n,
                        TriangleNormals::Flat,
                    )));
                }
            }
            continue;
        }
        let shape = match rng.u8(..4) {
            0 => Some(Shape::Sphere(Sphere {
                center: at,
                radius: size,
                inside: rng.u8(..5) == 0,
            })),
            1 | 2 => {
                // One in four in the plane z = 1 (coplanar neighbours, ties).
                let flat = rng.u8(..4) == 0;
                let mut corner = || {
                    let p = at + random_point(rng, size);
                    if flat {
                        Vec3::new(p.x, p.y, 1.0)
                    } else {
                        p
                    }
                };
                let (a, b, c) = (corner(), corner(), corner());
                let n = (b - a).cross(c - a).normalize_or_zero();
                (n != Vec3::ZERO)
                    .then(|| Shape::Triangle(Triangle::new(a, b, c, n, TriangleNormals::Flat)))
            }
            _ => {
                let apex = at + random_point(rng, size * 2.0);
                let base_radius = rng.f32() * size;
                let apex_radius = if rng.bool() {
                    base_radius
                } else {
                    rng.f32() * size
                };
                Cone::new(at, base_radius, apex, apex_radius, rng.u8(..5) == 0).map(Shape::Cone)
            }
        };
        shapes.extend(shape);
    }
    shapes
}

/// A packet of `K` rays: origins near the shapes, far from them (1e4) or
/// among them, lanes in nearly one direction or in any, `t_min` 0 or small,
/// `t_max` infinite or finite per lane, and a random non-empty mask.
pub fn random_packet<const K: usize>(rng: &mut fastrand::Rng) -> Packet<K> {
    let centre = random_point(rng, 12.0) * [1.0, 1.0, 1.0, 1e3][rng.usize(..4)];
    let toward = random_point(rng, 6.0);
    let coherent = rng.bool();
    let origins = std::array::from_fn(|_| centre + random_point(rng, 0.5));
    let dirs = std::array::from_fn(|l: usize| {
        if coherent {
            ((toward - origins[l]).normalize() + random_point(rng, 0.05)).normalize()
        } else {
            random_unit(rng)
        }
    });
    let t_max = std::array::from_fn(|_| {
        if rng.bool() {
            f32::INFINITY
        } else {
            rng.f32() * 30.0
        }
    });
    let all = if K == 32 { u32::MAX } else { (1u32 << K) - 1 };
    let mask = loop {
        let m = rng.u32(..) & all;
        if m != 0 {
            break if rng.bool() { all } else { m };
        }
    };
    Packet {
        origins,
        dirs,
        t_min: if rng.bool() { 0.0 } else { 1e-3 },
        t_max,
        mask,
    }
}

/// The packet's lanes as shadow segments (`0 < t < t_max`, `t_max` finite).
pub fn segments_of<const K: usize>(packet: &Packet<K>) -> SegmentPacket<K> {
    SegmentPacket {
        origins: packet.origins,
        dirs: packet.dirs,
        t_max: packet.t_max.map(|t| t.min(40.0)),
        mask: packet.mask,
    }
}

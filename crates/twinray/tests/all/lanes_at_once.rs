//! A packet's rays against one sphere or cone at once (issue 17, seventeenth
//! pass): where the eight rays of an eye packet, or the eight shadow segments
//! of a mono row's samples toward one light, enter a leaf of spheres and
//! cones together, the leaf's primitives are tested for all of them in one
//! eight-lane test (`Shape::intersect8`, through `NearestTest::test_lanes` and
//! `AnyHitTest::test_lanes`). On rings of tilted cylinders joined by spheres,
//! each lane's answer must stay brute force's, bit for bit, and the counts
//! must show the tests made together.

use crate::common;

use common::{brute, nff_world, rings};
use twinray::bvh::{NearestTest, Packet, PacketHits, SegmentPacket, TraversalStats};
use twinray::math::{Ray, Vec3};
use twinray::shading::shadow_packet;
use twinray::shapes::{EightHits, EightRays, Shape, SurfaceHit};
use wide::f32x8;

/// The renderer's nearest test, eight lanes at once unless `lanes_off`.
struct Nearest<'a> {
    shapes: &'a [Shape],
    packet: &'a Packet<8>,
    lanes_off: bool,
}

impl Nearest<'_> {
    fn ray(&self, lane: usize) -> Ray {
        Ray::new(self.packet.origins[lane], self.packet.dirs[lane])
    }
}

impl NearestTest for Nearest<'_> {
    fn test(&mut self, prim: u32, lane: usize, t_max: f32) -> Option<SurfaceHit> {
        self.shapes[prim as usize].intersect(&self.ray(lane), self.packet.t_min, t_max)
    }

    fn test_lanes(&mut self, prim: u32, _lanes: u32, t_max: f32x8) -> Option<EightHits> {
        if self.lanes_off {
            return None;
        }
        let rays = EightRays::new(|l| self.ray(l));
        self.shapes[prim as usize].intersect8(&rays, self.packet.t_min, t_max)
    }
}

/// More than one in `part` of the primitive tests `stats` counts were made
/// eight lanes at a time.
fn more_than_a_share_in_lanes(stats: &TraversalStats, part: u64) {
    assert!(
        stats.prim_tests_in_lanes * part > stats.prim_tests,
        "{} of {} primitive tests in lanes",
        stats.prim_tests_in_lanes,
        stats.prim_tests
    );
}

/// Packets of eight rays from one eye a little apart, toward neighbouring
/// points of the rings' region (an eye packet's shape).
fn eye_packets(count: usize, seed: u64) -> Vec<Packet<8>> {
    let mut rng = fastrand::Rng::with_seed(seed);
    let eye = Vec3::new(0.0, -12.0, 4.0);
    (0..count)
        .map(|_| {
            let at = Vec3::new(rng.f32() - 0.5, rng.f32() - 0.5, rng.f32() - 0.5)
                * Vec3::new(11.0, 11.0, 4.0)
                + Vec3::Z * 1.5;
            let step = Vec3::new(rng.f32(), 0.0, rng.f32()) * 0.02;
            let dirs: [Vec3; 8] = std::array::from_fn(|l| (at + step * l as f32 - eye).normalize());
            Packet {
                origins: [eye; 8],
                dirs,
                t_min: 0.0,
                t_max: [f32::INFINITY; 8],
                mask: rng.u32(1..256) | 0b11,
            }
        })
        .collect()
}

#[test]
fn eye_packets_meet_spheres_and_cones_lanes_at_once_as_brute_force_says() {
    let world = nff_world(&rings(60, 21));
    let shapes = &world.scene.shapes;
    let (mut on, mut off) = (TraversalStats::default(), TraversalStats::default());
    let (mut hits, mut refused) = (0, 0);
    for (n, packet) in eye_packets(1500, 5).iter().enumerate() {
        let mut found: Vec<PacketHits<8>> = Vec::new();
        for (lanes_off, stats) in [(false, &mut on), (true, &mut off)] {
            let test = Nearest {
                shapes,
                packet,
                lanes_off,
            };
            // None: the lanes' direction signs differ (the caller traces
            // them alone).
            if let Some(got) = world.bvh.closest_packet8(packet, stats, test) {
                found.push(got);
            }
        }
        refused += usize::from(found.is_empty());
        for l in (0..8).filter(|&l| packet.mask & (1 << l) != 0) {
            let ray = Ray::new(packet.origins[l], packet.dirs[l]);
            let expect = brute(shapes, &ray, 0.0, f32::INFINITY);
            for got in &found {
                let lane = got
                    .has_hit(l)
                    .then(|| (got.prim[l], got.hit[l].t.to_bits()));
                assert_eq!(
                    lane,
                    expect.map(|(p, h)| (p, h.t.to_bits())),
                    "packet {n}, lane {l}"
                );
            }
            hits += usize::from(expect.is_some() && !found.is_empty());
        }
    }
    assert!(
        hits > 3000 && refused < 100,
        "{hits} lanes hit, {refused} packets refused"
    );
    // The same tests, over half of them made eight lanes at a time.
    assert_eq!((on.nodes, on.prim_tests), (off.nodes, off.prim_tests));
    assert_eq!(off.prim_tests_in_lanes, 0);
    more_than_a_share_in_lanes(&on, 2);
}

#[test]
fn shadow_packets_are_blocked_lanes_at_once_as_brute_force_says() {
    let world = nff_world(&rings(60, 22));
    let shapes = &world.scene.shapes;
    let mut rng = fastrand::Rng::with_seed(9);
    let (mut stats, mut alone) = (TraversalStats::default(), TraversalStats::default());
    let (mut blocked, mut lit) = (0, 0);
    for n in 0..1500 {
        // Eight neighbouring points toward one light, as a mono row's samples.
        let spot = Vec3::new(rng.f32() - 0.5, rng.f32() - 0.5, rng.f32() * 0.5)
            * Vec3::new(11.0, 11.0, 4.0);
        let light = Vec3::new(
            rng.f32() * 8.0 - 4.0,
            -6.0 - rng.f32() * 4.0,
            6.0 + rng.f32() * 4.0,
        );
        let step = Vec3::new(rng.f32(), rng.f32(), rng.f32()) * 0.02;
        let origins: [Vec3; 8] = std::array::from_fn(|l| spot + step * l as f32);
        let segments = SegmentPacket {
            origins,
            dirs: origins.map(|o| (light - o).normalize()),
            t_max: origins.map(|o| (light - o).length()),
            mask: rng.u32(1..256) | 0b11,
        };
        let (through, _) = shadow_packet(&world, &segments, &mut stats);
        // Each lane alone, for the count of its tests.
        for l in (0..8).filter(|&l| segments.mask & (1 << l) != 0) {
            let one = SegmentPacket {
                mask: 1 << l,
                ..segments
            };
            shadow_packet(&world, &one, &mut alone);
        }
        for l in (0..8).filter(|&l| segments.mask & (1 << l) != 0) {
            let ray = Ray::new(segments.origins[l], segments.dirs[l]);
            let met = shapes
                .iter()
                .any(|s| s.intersect(&ray, 0.0, segments.t_max[l]).is_some());
            assert_eq!(
                through[l],
                if met { 0.0 } else { 1.0 },
                "packet {n}, lane {l}"
            );
            if met {
                blocked += 1;
            } else {
                lit += 1;
            }
        }
    }
    assert!(blocked > 1000 && lit > 1000, "{blocked} blocked, {lit} lit");
    // The tests made are counted, not the leaf's size: a lane that stopped
    // tests nothing more, in the packet as alone.
    assert_eq!(stats.prim_tests, alone.prim_tests);
    assert_eq!(alone.prim_tests_in_lanes, 0);
    more_than_a_share_in_lanes(&stats, 3);
}

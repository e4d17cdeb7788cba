//! Ray sets for timing the traversals on real scenes: the eye rays of an NFF
//! file's viewpoint through the pixel centres (as `../shared/bench/vs-embree.py`
//! casts them), stereo pairs and packets of views of those, and the shadow and
//! reflected rays of their hits. Each pass returns a checksum of the hits so
//! that two ways of tracing can be seen to agree and nothing is optimised
//! away.
//!
//! Nearest hits test leaves of triangles four at a time, as the renderer
//! does (`Bvh::blocks`); `Tree::Scalar` tests every primitive one by one, and
//! `Tree::Lanes` traces each lane of a packet alone, for comparison.

use std::path::Path;

use rayon::prelude::*;
use twinray::bvh::{AnyHit, AnyHitTest, Bvh, NearestTest, Packet, SegmentPacket, TraversalStats};
use twinray::loaders::{load_scene, LoadOptions};
use twinray::math::{reflect, Ray, Vec3};
use twinray::shapes::{BlockHits, Shape, SurfaceHit, Triangle4};
use twinray::World;

/// How a pass traces its rays.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Tree {
    /// As the renderer does (`Bvh::closest`, `Bvh::occlusion`): a pair's
    /// shadow segments and packets of eight in one descent, leaves of
    /// triangles as blocks.
    Packets,
    /// Every lane of a packet, and every segment, alone, leaves as blocks.
    Lanes,
    /// As `Packets`, with every leaf primitive tested one by one.
    Scalar,
}

impl Tree {
    fn blocks(self) -> bool {
        self != Tree::Scalar
    }
}

/// The renderer's nearest test for rays `rays` (one per lane): leaves held as
/// blocks four at a time when `blocks`.
struct Nearest<'a, const K: usize> {
    shapes: &'a [Shape],
    blocks: bool,
    rays: &'a [Ray; K],
}

impl<const K: usize> NearestTest for Nearest<'_, K> {
    #[inline(always)]
    fn test(&mut self, prim: u32, lane: usize, t_max: f32) -> Option<SurfaceHit> {
        self.shapes[prim as usize].intersect(&self.rays[lane], 0.0, t_max)
    }

    #[inline(always)]
    fn test_block(&mut self, block: &Triangle4, lane: usize, t_max: f32) -> Option<BlockHits> {
        self.blocks
            .then(|| block.intersect(&self.rays[lane], 0.0, t_max))
    }

    #[inline(always)]
    fn test_two_blocks(
        &mut self,
        blocks: &[Triangle4; 2],
        lane: usize,
        t_max: f32,
    ) -> Option<[BlockHits; 2]> {
        self.blocks
            .then(|| Triangle4::intersect_two(blocks, &self.rays[lane], 0.0, t_max))
    }
}

/// The nearest hits of a packet of rays on `tree`.
#[inline(always)]
fn nearest<const K: usize>(
    bvh: &Bvh,
    world: &World,
    rays: &[Ray; K],
    tree: Tree,
    st: &mut TraversalStats,
) -> twinray::bvh::PacketHits<K> {
    let p = Packet {
        origins: rays.map(|r| r.origin),
        dirs: rays.map(|r| r.dir),
        t_min: 0.0,
        t_max: [f32::INFINITY; K],
        mask: (1 << K) - 1,
    };
    let shapes = &world.scene.shapes;
    let blocks = tree.blocks();
    if tree != Tree::Lanes {
        return bvh.closest(
            &p,
            st,
            Nearest {
                shapes,
                blocks,
                rays,
            },
        );
    }
    let none = SurfaceHit {
        t: f32::INFINITY,
        u: 0.0,
        v: 0.0,
    };
    let mut out = twinray::bvh::PacketHits {
        prim: [u32::MAX; K],
        hit: [none; K],
    };
    for l in 0..K {
        let rays = &[rays[l]];
        let h = bvh.closest(
            &p.lane(l),
            st,
            Nearest {
                shapes,
                blocks,
                rays,
            },
        );
        (out.prim[l], out.hit[l]) = (h.prim[0], h.hit[0]);
    }
    out
}

/// A scene with the rays of one `size`² view of it.
pub struct RaySets {
    pub world: World,
    /// Eye rays through the pixel centres, in scanline order.
    pub eye: Vec<Ray>,
    /// Stereo pairs: each eye ray and the same pixel's ray from an eye moved
    /// along the camera's right axis by 2 % of the distance to the target.
    pub pairs: Vec<[Ray; 2]>,
    /// From each eye hit toward the first light (or a point above the scene):
    /// origin, direction, length.
    pub shadow: Vec<(Vec3, Vec3, f32)>,
    /// The mirror reflections of the eye rays at their hits.
    pub reflected: Vec<Ray>,
    /// Shadow segments of the pairs whose two rays both hit: the twin
    /// method's two-lane shadow packets.
    pub shadow_pairs: Vec<[(Vec3, Vec3, f32); 2]>,
    /// Four views: each eye ray and the same pixel's rays from eyes moved
    /// along the right axis by 2/3, 4/3 and 2 % of the distance to the
    /// target (a four-lane twin packet).
    pub quads: Vec<[Ray; 4]>,
    /// Eight views likewise, eyes 2/7 % apart: an eight-lane twin packet
    /// (`--views-per-batch 8`).
    pub octs: Vec<[Ray; 8]>,
    /// Shadow segments of the quads whose four rays all hit: the twin
    /// method's four-lane shadow packets.
    pub shadow_quads: Vec<[(Vec3, Vec3, f32); 4]>,
}

impl RaySets {
    /// Loads `path` and casts its rays at `size`² pixels.
    pub fn load(path: &Path, size: usize) -> twinray::Result<RaySets> {
        let scene = load_scene(path, &LoadOptions::default())?;
        let world = World::new(scene);
        let vp = world.scene.viewpoint.clone();
        let fwd = (vp.at - vp.from).normalize();
        let right = fwd.cross(vp.up).normalize();
        let up = right.cross(fwd);
        let half = (vp.angle_deg.to_radians() * 0.5).tan();
        let px = half / ((size as f32 - 1.0) * 0.5);
        let eye2 = vp.from + right * (0.02 * (vp.at - vp.from).length());
        let mut eye = Vec::with_capacity(size * size);
        let mut pairs = Vec::with_capacity(size * size);
        let mut quads = Vec::with_capacity(size * size);
        let mut octs = Vec::with_capacity(size * size);
        let eyes: [Vec3; 4] = std::array::from_fn(|k| {
            vp.from + right * (0.02 * k as f32 / 3.0 * (vp.at - vp.from).length())
        });
        let eyes8: [Vec3; 8] = std::array::from_fn(|k| {
            vp.from + right * (0.02 * k as f32 / 7.0 * (vp.at - vp.from).length())
        });
        for j in 0..size {
            for i in 0..size {
                let x = (i as f32 - (size as f32 - 1.0) * 0.5) * px;
                let y = ((size as f32 - 1.0) * 0.5 - j as f32) * px;
                let dir = (fwd + right * x + up * y).normalize();
                eye.push(Ray::new(vp.from, dir));
                pairs.push([Ray::new(vp.from, dir), Ray::new(eye2, dir)]);
                quads.push(eyes.map(|e| Ray::new(e, dir)));
                octs.push(eyes8.map(|e| Ray::new(e, dir)));
            }
        }
        let light = world
            .scene
            .lights
            .iter()
            .find_map(|l| match l.kind {
                twinray::lights::LightKind::Point { position, .. } => Some(position),
                _ => None,
            })
            .unwrap_or(vp.from + up * 100.0);
        let (mut shadow, mut reflected, mut shadow_pairs) = (Vec::new(), Vec::new(), Vec::new());
        let shapes = &world.scene.shapes;
        // The hit of `ray`: a shadow segment from it and its mirror reflection.
        let spawn = |ray: &Ray| {
            let (prim, t) = closest(
                &world.bvh,
                &world,
                ray,
                Tree::Packets,
                &mut TraversalStats::default(),
            );
            if prim == u32::MAX {
                return None;
            }
            let p = ray.at(t);
            let h = twinray::shapes::SurfaceHit { t, u: 0.0, v: 0.0 };
            let n = shapes[prim as usize].normal(p, &h, &world.scene.corners);
            let n = if n.dot(ray.dir) > 0.0 { -n } else { n };
            let o = p + n * 1e-3;
            let to = light - o;
            Some((
                (o, to.normalize(), to.length()),
                Ray::new(o, reflect(ray.dir, n)),
            ))
        };
        for pair in &pairs {
            let (a, b) = (spawn(&pair[0]), spawn(&pair[1]));
            if let Some((s, r)) = a {
                shadow.push(s);
                reflected.push(r);
            }
            if let (Some((s0, _)), Some((s1, _))) = (a, b) {
                shadow_pairs.push([s0, s1]);
            }
        }
        let shadow_quads = quads
            .iter()
            .filter_map(|q| {
                let s: [Option<(Vec3, Vec3, f32)>; 4] =
                    std::array::from_fn(|k| Some(spawn(&q[k])?.0));
                s.iter()
                    .all(Option::is_some)
                    .then(|| s.map(|x| x.unwrap_or_default()))
            })
            .collect();
        Ok(RaySets {
            world,
            eye,
            pairs,
            shadow,
            reflected,
            shadow_pairs,
            quads,
            octs,
            shadow_quads,
        })
    }
}

/// One ray's nearest hit: `(prim, t)`, `(u32::MAX, inf)` for none.
#[inline(always)]
pub fn closest(
    bvh: &Bvh,
    world: &World,
    ray: &Ray,
    tree: Tree,
    st: &mut TraversalStats,
) -> (u32, f32) {
    let h = nearest(bvh, world, &[*ray], tree, st);
    (h.prim[0], h.hit[0].t)
}

fn checksum(prim: u32, t: f32) -> u64 {
    prim as u64 ^ t.to_bits() as u64
}

/// Runs `f` over `items` on `threads` threads (1: on this one), summing checksums.
fn pass<T: Sync>(items: &[T], threads: usize, f: impl Fn(&T) -> u64 + Sync) -> u64 {
    if threads <= 1 {
        return items.iter().map(&f).fold(0, u64::wrapping_add);
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("a thread pool");
    pool.install(|| {
        items
            .par_chunks(1024)
            .map(|c| c.iter().map(&f).fold(0, u64::wrapping_add))
            .reduce(|| 0, u64::wrapping_add)
    })
}

/// Nearest hits of single rays (eye or reflected).
pub fn rays_pass(sets: &RaySets, rays: &[Ray], tree: Tree, threads: usize) -> u64 {
    let w = &sets.world;
    pass(rays, threads, |r| {
        let (p, t) = closest(&w.bvh, w, r, tree, &mut TraversalStats::default());
        checksum(p, t)
    })
}

/// Nearest hits of stereo pairs traced as two-lane packets (the twin method's descent).
pub fn pairs_pass(sets: &RaySets, tree: Tree, threads: usize) -> u64 {
    let w = &sets.world;
    pass(&sets.pairs, threads, |pair| {
        let h = nearest(&w.bvh, w, pair, tree, &mut TraversalStats::default());
        checksum(h.prim[0], h.hit[0].t).wrapping_add(checksum(h.prim[1], h.hit[1].t))
    })
}

/// The work of tracing the stereo pairs as two-lane packets on `tree`.
pub fn pair_work(sets: &RaySets, tree: Tree) -> TraversalStats {
    let mut st = TraversalStats::default();
    for pair in &sets.pairs {
        nearest(&sets.world.bvh, &sets.world, pair, tree, &mut st);
    }
    st
}

/// Nearest hits of the four-view packets (`RaySets::quads`).
pub fn quads_pass(sets: &RaySets, tree: Tree, threads: usize) -> u64 {
    let w = &sets.world;
    pass(&sets.quads, threads, |rays| {
        let h = nearest(&w.bvh, w, rays, tree, &mut TraversalStats::default());
        (0..4).fold(0u64, |a, l| a.wrapping_add(checksum(h.prim[l], h.hit[l].t)))
    })
}

/// Nearest hits of the eight-view packets (`RaySets::octs`).
pub fn octs_pass(sets: &RaySets, tree: Tree, threads: usize) -> u64 {
    let w = &sets.world;
    pass(&sets.octs, threads, |rays| {
        let h = nearest(&w.bvh, w, rays, tree, &mut TraversalStats::default());
        (0..8).fold(0u64, |a, l| a.wrapping_add(checksum(h.prim[l], h.hit[l].t)))
    })
}

/// Any-hit of the four-lane shadow packets (`RaySets::shadow_quads`).
pub fn shadow_quads_pass(sets: &RaySets, tree: Tree, threads: usize) -> u64 {
    pass(&sets.shadow_quads, threads, |segs| {
        any_hits(&sets.world, *segs, tree, &mut TraversalStats::default())
    })
}

/// Any-hit of the shadow segments, one at a time, stopping at the first blocker.
pub fn shadow_pass(sets: &RaySets, tree: Tree, threads: usize) -> u64 {
    pass(&sets.shadow, threads, |s| {
        any_hits(&sets.world, [*s], tree, &mut TraversalStats::default())
    })
}

/// Whether the segment `(origin, dir, length)` meets anything, traced alone.
pub fn shadow_blocked(w: &World, seg: &(Vec3, Vec3, f32), tree: Tree) -> bool {
    any_hits(w, [*seg], tree, &mut TraversalStats::default()) != 0
}

/// The work of tracing the shadow segments one at a time.
pub fn shadow_work(sets: &RaySets, tree: Tree) -> TraversalStats {
    let mut st = TraversalStats::default();
    for s in &sets.shadow {
        any_hits(&sets.world, [*s], tree, &mut st);
    }
    st
}

/// Whether each lane's segment `(origin, dir, length)`, traced as one packet,
/// is blocked (bit `l` for lane `l`).
#[inline(always)]
fn any_hits<const K: usize>(
    w: &World,
    segs: [(Vec3, Vec3, f32); K],
    tree: Tree,
    st: &mut TraversalStats,
) -> u64 {
    let shapes = &w.scene.shapes;
    let p = SegmentPacket {
        origins: segs.map(|s| s.0),
        dirs: segs.map(|s| s.1),
        t_max: segs.map(|s| s.2),
        mask: (1 << K) - 1,
    };
    let rays = segs.map(|(o, d, _)| Ray::new(o, d));
    let mut test = Blocked {
        shapes,
        blocks: tree.blocks(),
        rays: &rays,
        lengths: segs.map(|s| s.2),
        blocked: 0,
    };
    if tree != Tree::Lanes {
        w.bvh.occlusion(&p, st, &mut test);
        return test.blocked;
    }
    (0..K).fold(0, |blocked, l| {
        blocked | any_hits(w, [segs[l]], Tree::Packets, st) << l
    })
}

/// The renderer's any-hit test for opaque scenes (`shading::ShadowTest`):
/// a lane stops at the first primitive its segment meets; leaves of
/// triangles four at a time when `blocks`.
struct Blocked<'a, const K: usize> {
    shapes: &'a [Shape],
    blocks: bool,
    rays: &'a [Ray; K],
    lengths: [f32; K],
    /// Bit `l`: lane `l` met something.
    blocked: u64,
}

impl<const K: usize> Blocked<'_, K> {
    fn stop(&mut self, lane: usize) -> AnyHit {
        self.blocked |= 1 << lane;
        AnyHit::Stop
    }
}

impl<const K: usize> AnyHitTest for Blocked<'_, K> {
    #[inline(always)]
    fn test(&mut self, prim: u32, lane: usize) -> AnyHit {
        let shape = &self.shapes[prim as usize];
        match shape.intersect(&self.rays[lane], 0.0, self.lengths[lane]) {
            Some(_) => self.stop(lane),
            None => AnyHit::Continue,
        }
    }

    #[inline(always)]
    fn test_block(&mut self, block: &Triangle4, prims: &[u32], lane: usize) -> Option<AnyHit> {
        if !self.blocks {
            return None;
        }
        let hits = block.intersect(&self.rays[lane], 0.0, self.lengths[lane]);
        Some(if hits.first(prims.len()).next().is_some() {
            self.stop(lane)
        } else {
            AnyHit::Continue
        })
    }
}

/// The work of tracing `rays` one at a time: nodes, box tests, primitive tests.
pub fn work(sets: &RaySets, rays: &[Ray], tree: Tree) -> TraversalStats {
    let mut st = TraversalStats::default();
    for r in rays {
        closest(&sets.world.bvh, &sets.world, r, tree, &mut st);
    }
    st
}

/// Any-hit of the shadow segment pairs as two-lane packets, stopping each lane
/// at its first blocker.
pub fn shadow_pairs_pass(sets: &RaySets, tree: Tree, threads: usize) -> u64 {
    pass(&sets.shadow_pairs, threads, |segs| {
        any_hits(&sets.world, *segs, tree, &mut TraversalStats::default())
    })
}

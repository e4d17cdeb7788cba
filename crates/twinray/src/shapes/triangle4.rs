//! A hierarchy leaf's triangles stored four to a block in structure-of-arrays
//! layout (vertex, edges and plane normal precomputed, as `Triangle` keeps
//! them), so that one ray meets all four in one SIMD stream (`wide::f32x4`).
//!
//! Exactness: each register lane does `Triangle::intersect`'s IEEE operations
//! in the same order (glam's `dot` and `cross` written out, no fused
//! multiply-add: Rust never fuses on its own), so bit `i` of the answer and its
//! `t`, `u`, `v` are bit for bit what `intersect` gives for the block's
//! triangle `i`. Every method (mono, twin, shared, quilt) calls this one routine.

use super::triangle::{intersect_lanes, kept_lanes};
use super::{Shape, SurfaceHit, Triangle};
use crate::math::Ray;
use wide::{f32x4, f32x8};

/// Triangles per block. A hierarchy built for blocks
/// (`bvh::BuildOptions::block`) starts every leaf at a slot that is a
/// multiple of this, so that slot `s` lies in block `s / BLOCK`.
pub const BLOCK: usize = 4;

/// Up to four triangles, component by component: 192 bytes, three cache
/// lines. An unused lane has zero edges: its determinant is 0, which no ray
/// passes (and the leaf tests mask lanes beyond the leaf's count too).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub struct Triangle4 {
    v0: [f32x4; 3],
    e1: [f32x4; 3],
    e2: [f32x4; 3],
    n: [f32x4; 3],
}

/// What a block's test found: bit `i` of `mask` set where triangle `i` is hit
/// with `t_min < t < t_max`, and its `t`, `u`, `v` in lane `i`.
#[derive(Clone, Copy, Debug)]
pub struct BlockHits {
    pub mask: u32,
    pub t: [f32; BLOCK],
    pub u: [f32; BLOCK],
    pub v: [f32; BLOCK],
}

impl BlockHits {
    /// The hits among the first `n` lanes, in lane order, with their lanes.
    #[inline(always)]
    pub fn first(&self, n: usize) -> impl Iterator<Item = (usize, SurfaceHit)> + '_ {
        let mut m = self.mask & ((1u32 << n) - 1);
        std::iter::from_fn(move || {
            (m != 0).then(|| {
                let i = m.trailing_zeros() as usize;
                m &= m - 1;
                let hit = SurfaceHit {
                    t: self.t[i],
                    u: self.u[i],
                    v: self.v[i],
                };
                (i, hit)
            })
        })
    }
}

impl Triangle4 {
    /// A block of no triangles: every lane's edges zero.
    pub const EMPTY: Triangle4 = Triangle4 {
        v0: [f32x4::ZERO; 3],
        e1: [f32x4::ZERO; 3],
        e2: [f32x4::ZERO; 3],
        n: [f32x4::ZERO; 3],
    };

    /// The block of `tris` (at most `BLOCK`).
    pub fn new(tris: &[&Triangle]) -> Triangle4 {
        assert!(tris.len() <= BLOCK, "{} triangles in a block", tris.len());
        let lane = |f: &dyn Fn(&Triangle) -> f32| {
            let mut a = [0.0f32; BLOCK];
            for (x, t) in a.iter_mut().zip(tris) {
                *x = f(t);
            }
            f32x4::from(a)
        };
        Triangle4 {
            v0: [lane(&|t| t.v0.x), lane(&|t| t.v0.y), lane(&|t| t.v0.z)],
            e1: [lane(&|t| t.e1.x), lane(&|t| t.e1.y), lane(&|t| t.e1.z)],
            e2: [lane(&|t| t.e2.x), lane(&|t| t.e2.y), lane(&|t| t.e2.z)],
            n: [
                lane(&|t| t.plane_normal.x),
                lane(&|t| t.plane_normal.y),
                lane(&|t| t.plane_normal.z),
            ],
        }
    }

    /// `Triangle::intersect` of `ray` with the four triangles at once.
    #[inline(always)]
    pub fn intersect(&self, ray: &Ray, t_min: f32, t_max: f32) -> BlockHits {
        let sp = f32x4::splat;
        let dir = [ray.dir.x, ray.dir.y, ray.dir.z].map(sp);
        let org = [ray.origin.x, ray.origin.y, ray.origin.z].map(sp);
        let found = intersect_lanes(dir, org, [self.v0, self.e1, self.e2, self.n], f32x4::ONE);
        let mask = kept_lanes!(f32x4, found, sp(t_min), sp(t_max));
        let [_, u, v, t] = found;
        BlockHits {
            mask,
            t: t.to_array(),
            u: u.to_array(),
            v: v.to_array(),
        }
    }
}

impl Triangle4 {
    /// `intersect` for two rays at once (a stereo pair), the four triangles
    /// twice over in one eight-wide register: lanes 0-3 the first ray's,
    /// 4-7 the second's; per lane the same operations as `intersect`.
    #[inline(always)]
    pub fn intersect_pair(&self, rays: &[Ray; 2], t_min: f32, t_max: [f32; 2]) -> [BlockHits; 2] {
        let twice = |v: f32x4| {
            let a = v.to_array();
            f32x8::from([a[0], a[1], a[2], a[3], a[0], a[1], a[2], a[3]])
        };
        let each = |a: f32, b: f32| f32x8::from([a, a, a, a, b, b, b, b]);
        let (r0, r1) = (&rays[0], &rays[1]);
        let dir = [0, 1, 2].map(|a| each(r0.dir[a], r1.dir[a]));
        let org = [0, 1, 2].map(|a| each(r0.origin[a], r1.origin[a]));
        let tri = [self.v0, self.e1, self.e2, self.n].map(|c| c.map(twice));
        let found = intersect_lanes(dir, org, tri, f32x8::ONE);
        let hi = each(t_max[0], t_max[1]);
        let mask = kept_lanes!(f32x8, found, f32x8::splat(t_min), hi);
        let [_, u, v, t] = found;
        halves(mask, t.to_array(), u.to_array(), v.to_array())
    }
}

impl Triangle4 {
    /// `intersect` of two blocks at once (a leaf of five to eight
    /// triangles, its blocks side by side) in one eight-wide register:
    /// lanes 0-3 `blocks[0]`'s triangles, 4-7 `blocks[1]`'s; per lane the
    /// same operations as `intersect`, so each half is bit for bit what
    /// `intersect` gives that block. One register test instead of two: the
    /// leaf half of an eye ray's work on `--samples 1` renders
    /// (docs/benchmarks.md, "Issue 17, fifth pass").
    #[inline(always)]
    pub fn intersect_two(
        blocks: &[Triangle4; 2],
        ray: &Ray,
        t_min: f32,
        t_max: f32,
    ) -> [BlockHits; 2] {
        let both = |a: f32x4, b: f32x4| {
            let (a, b) = (a.to_array(), b.to_array());
            f32x8::from([a[0], a[1], a[2], a[3], b[0], b[1], b[2], b[3]])
        };
        let [p, q] = blocks;
        let join = |a: &[f32x4; 3], b: &[f32x4; 3]| [0, 1, 2].map(|c| both(a[c], b[c]));
        let tri = [
            join(&p.v0, &q.v0),
            join(&p.e1, &q.e1),
            join(&p.e2, &q.e2),
            join(&p.n, &q.n),
        ];
        let sp = f32x8::splat;
        let dir = [ray.dir.x, ray.dir.y, ray.dir.z].map(sp);
        let org = [ray.origin.x, ray.origin.y, ray.origin.z].map(sp);
        let found = intersect_lanes(dir, org, tri, f32x8::ONE);
        let mask = kept_lanes!(f32x8, found, sp(t_min), sp(t_max));
        let [_, u, v, t] = found;
        halves(mask, t.to_array(), u.to_array(), v.to_array())
    }
}

/// An eight-lane answer (`mask`, `t`, `u`, `v`) as two blocks' answers:
/// lanes 0-3 the first, 4-7 the second.
#[inline(always)]
fn halves(mask: u32, t: [f32; 8], u: [f32; 8], v: [f32; 8]) -> [BlockHits; 2] {
    let half = |h: usize| {
        let at = |a: &[f32; 8]| [a[4 * h], a[4 * h + 1], a[4 * h + 2], a[4 * h + 3]];
        BlockHits {
            mask: (mask >> (BLOCK * h)) & 0xf,
            t: at(&t),
            u: at(&u),
            v: at(&v),
        }
    };
    [half(0), half(1)]
}

/// A hierarchy's leaves of triangles as blocks, indexed by slot: block `k`
/// holds the triangles in slots `BLOCK * k ..` of a leaf that starts at a
/// multiple of `BLOCK` (`bvh::BuildOptions::block`). The traversals find a
/// leaf's blocks from its first slot and count, with no table between.
#[derive(Clone, Debug, Default)]
pub struct LeafBlocks {
    pub(crate) tris: Vec<Triangle4>,
    /// Per block: how many of its lanes hold triangles of a leaf made only of
    /// triangles (0: the leaf's primitives are tested one by one).
    pub(crate) lanes: Vec<u8>,
}

impl LeafBlocks {
    /// Number of blocks that hold triangles.
    pub fn len(&self) -> usize {
        self.lanes.iter().filter(|&&l| l != 0).count()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Triangles held in blocks.
    pub fn triangles(&self) -> usize {
        self.lanes.iter().map(|&l| l as usize).sum()
    }

    /// Memory held, in bytes.
    pub fn memory_bytes(&self) -> usize {
        self.tris.len() * std::mem::size_of::<Triangle4>() + self.lanes.len()
    }

    /// The blocks of the leaf at slots `first..first + count`, or none if
    /// they are not held as blocks.
    #[inline(always)]
    pub fn of_leaf(&self, first: usize, count: usize) -> &[Triangle4] {
        let k = first / BLOCK;
        match self.lanes.get(k) {
            Some(&l) if l != 0 && first.is_multiple_of(BLOCK) => {
                &self.tris[k..k + count.div_ceil(BLOCK)]
            }
            _ => &[],
        }
    }

    /// Blocks for every leaf `(first, prims)` (its first slot and its
    /// primitives, indices into `shapes`) that starts at a multiple of
    /// `BLOCK` and holds only triangles; `slots`: the length of the order.
    /// Other leaves keep the scalar tests. No such leaf: no blocks at all.
    /// The blocks are made on all threads (each from its own slots).
    pub fn new<'a>(
        shapes: &[Shape],
        slots: usize,
        leaves: impl Iterator<Item = (usize, &'a [u32])>,
    ) -> LeafBlocks {
        use rayon::prelude::*;
        let triangle = |p: u32| match shapes.get(p as usize) {
            Some(Shape::Triangle(t)) => Some(t),
            _ => None,
        };
        // Per block: the primitives of its lanes (a leaf's, `BLOCK` at a time).
        let mut lanes: Vec<&[u32]> = Vec::new();
        for (first, prims) in leaves {
            if !first.is_multiple_of(BLOCK)
                || prims.is_empty()
                || !prims.iter().all(|&p| triangle(p).is_some())
            {
                continue;
            }
            if lanes.is_empty() {
                lanes = vec![&[]; slots.div_ceil(BLOCK)];
            }
            for (i, chunk) in prims.chunks(BLOCK).enumerate() {
                lanes[first / BLOCK + i] = chunk;
            }
        }
        let tris = lanes
            .par_iter()
            .map(|prims| {
                let tris: arrayvec::ArrayVec<&Triangle, BLOCK> =
                    prims.iter().filter_map(|&p| triangle(p)).collect();
                Triangle4::new(&tris)
            })
            .collect();
        LeafBlocks {
            tris,
            lanes: lanes.iter().map(|p| p.len() as u8).collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;
    use crate::shapes::{SurfaceHit, TriangleNormals};

    fn vec(g: &mut fastrand::Rng, scale: f32) -> Vec3 {
        Vec3::new(g.f32() - 0.5, g.f32() - 0.5, g.f32() - 0.5) * scale
    }

    fn bits(h: Option<SurfaceHit>) -> Option<[u32; 3]> {
        h.map(|h| [h.t.to_bits(), h.u.to_bits(), h.v.to_bits()])
    }

    fn tri(a: Vec3, b: Vec3, c: Vec3) -> Triangle {
        let n = (b - a).cross(c - a).normalize_or_zero();
        Triangle::new(a, b, c, n, TriangleNormals::Flat)
    }

    /// Each lane is `Triangle::intersect`, bit for bit: random triangles,
    /// slivers, degenerate ones (a point, a line), triangles edge-on to the
    /// ray, and rays aimed at vertices and at edges shared by two triangles.
    #[test]
    fn each_lane_is_the_scalar_test_bit_for_bit() {
        let mut g = fastrand::Rng::with_seed(23);
        let (mut hits, mut cases) = (0, 0);
        for round in 0..3000 {
            let (a, b, c) = (vec(&mut g, 4.0), vec(&mut g, 4.0), vec(&mut g, 4.0));
            let d = vec(&mut g, 4.0);
            let tris = [
                tri(a, b, c),
                // Shares the edge b-c with the first.
                tri(c, b, d),
                match round % 4 {
                    0 => tri(a, a, a),
                    1 => tri(a, b, a + (b - a) * 0.5),
                    2 => tri(a, b, b + Vec3::new(1e-7, 0.0, 0.0)),
                    _ => tri(d, a, c),
                },
                tri(a + Vec3::Z, b + Vec3::Z, c + Vec3::Z),
            ];
            let n = 1 + round % BLOCK;
            let refs: Vec<&Triangle> = tris[..n].iter().collect();
            let block = Triangle4::new(&refs);
            let target = match round % 5 {
                0 => a,
                1 => b + (c - b) * g.f32(),
                2 => a + (b - a) * 0.5,
                3 => (a + b + c) / 3.0,
                _ => vec(&mut g, 4.0),
            };
            let origin = if round % 7 == 0 {
                // In the first triangle's plane: edge-on.
                a + (b - a) * 3.0 + (c - a) * -2.0
            } else {
                vec(&mut g, 30.0)
            };
            let dir = (target - origin).normalize_or(Vec3::Z);
            let ray = Ray::new(origin, dir);
            let t_max = if round % 3 == 0 {
                f32::INFINITY
            } else {
                g.f32() * 30.0
            };
            let got = block.intersect(&ray, 1e-4, t_max);
            assert_eq!(got.mask >> n, 0, "unused lanes never hit");
            for (i, t) in tris[..n].iter().enumerate() {
                let single = t.intersect(&ray, 1e-4, t_max);
                let lane = (got.mask & (1 << i) != 0).then_some(SurfaceHit {
                    t: got.t[i],
                    u: got.u[i],
                    v: got.v[i],
                });
                assert_eq!(bits(lane), bits(single), "round {round}, lane {i}");
                hits += single.is_some() as u32;
                cases += 1;
            }
        }
        assert!(hits > cases / 5, "{hits} hits of {cases}");
    }

    /// The pair test gives each ray what `intersect` gives it, bit for bit.
    #[test]
    fn the_pair_test_is_two_block_tests() {
        let mut g = fastrand::Rng::with_seed(29);
        let mut hits = 0;
        for round in 0..2000 {
            let (a, b, c) = (vec(&mut g, 4.0), vec(&mut g, 4.0), vec(&mut g, 4.0));
            let tris = [
                tri(a, b, c),
                tri(c, b, a + Vec3::Z),
                tri(a, a, b),
                tri(b, c, c + Vec3::X),
            ];
            let n = 1 + round % BLOCK;
            let refs: Vec<&Triangle> = tris[..n].iter().collect();
            let block = Triangle4::new(&refs);
            let o = vec(&mut g, 30.0);
            let target = [a, b + (c - b) * 0.5, (a + b + c) / 3.0][round % 3];
            let o2 = o + vec(&mut g, 0.5);
            let rays = [o, o2].map(|o| Ray::new(o, (target - o).normalize_or(Vec3::Z)));
            let t_max = [f32::INFINITY, g.f32() * 40.0];
            let pair = block.intersect_pair(&rays, 1e-4, t_max);
            for l in 0..2 {
                let one = block.intersect(&rays[l], 1e-4, t_max[l]);
                assert_eq!(pair[l].mask, one.mask, "round {round}, ray {l}");
                for i in 0..BLOCK {
                    if one.mask & (1 << i) != 0 {
                        let bits =
                            |h: &BlockHits| [h.t[i].to_bits(), h.u[i].to_bits(), h.v[i].to_bits()];
                        assert_eq!(bits(&pair[l]), bits(&one));
                        hits += 1;
                    }
                }
            }
        }
        assert!(hits > 1000, "{hits}");
    }

    /// The two-block test gives each block what `intersect` gives it, bit
    /// for bit, whichever lanes of either block are in use and wherever the
    /// ray meets them (vertices, shared edges, edge-on, degenerate lanes).
    #[test]
    fn the_two_block_test_is_two_block_tests() {
        let mut g = fastrand::Rng::with_seed(31);
        let (mut hits, mut second) = (0, 0);
        for round in 0..3000 {
            let (a, b, c) = (vec(&mut g, 4.0), vec(&mut g, 4.0), vec(&mut g, 4.0));
            let d = vec(&mut g, 4.0);
            let tris = [
                tri(a, b, c),
                tri(c, b, d),
                tri(a, a, a),
                tri(a + Vec3::Z, b + Vec3::Z, c + Vec3::Z),
                tri(d, a, c),
                tri(b, c, c + Vec3::X),
                tri(a, b, a + (b - a) * 0.5),
                tri(a - Vec3::Z, c - Vec3::Z, d - Vec3::Z),
            ];
            // Five to eight triangles: the first block full, the second not always.
            let n = 5 + round % 4;
            let refs: Vec<&Triangle> = tris[..n].iter().collect();
            let blocks = [
                Triangle4::new(&refs[..BLOCK]),
                Triangle4::new(&refs[BLOCK..]),
            ];
            let target = match round % 5 {
                0 => [a, d, c, b][round % 4],
                1 => b + (c - b) * g.f32(),
                2 => (a + c) * 0.5,
                3 => (a + b + c) / 3.0 - Vec3::Z,
                _ => vec(&mut g, 4.0),
            };
            let origin = if round % 7 == 0 {
                a + (b - a) * 3.0 + (c - a) * -2.0
            } else {
                vec(&mut g, 30.0)
            };
            let ray = Ray::new(origin, (target - origin).normalize_or(Vec3::Z));
            let t_max = [f32::INFINITY, g.f32() * 30.0][round % 2];
            let two = Triangle4::intersect_two(&blocks, &ray, 1e-4, t_max);
            for (k, block) in blocks.iter().enumerate() {
                let one = block.intersect(&ray, 1e-4, t_max);
                assert_eq!(two[k].mask, one.mask, "round {round}, block {k}");
                for i in 0..BLOCK {
                    if one.mask & (1 << i) != 0 {
                        let bits =
                            |h: &BlockHits| [h.t[i].to_bits(), h.u[i].to_bits(), h.v[i].to_bits()];
                        assert_eq!(bits(&two[k]), bits(&one), "round {round}, block {k}");
                        hits += 1;
                        second += k;
                    }
                }
            }
        }
        assert!(
            hits > 1500 && second > 500,
            "{hits} hits, {second} in the second block"
        );
    }

    #[test]
    fn blocks_are_made_for_aligned_leaves_of_triangles_only() {
        let t = |x: f32| {
            Shape::Triangle(tri(
                Vec3::new(x, 0.0, 0.0),
                Vec3::new(x + 1.0, 0.0, 0.0),
                Vec3::new(x, 1.0, 0.0),
            ))
        };
        let sphere = Shape::Sphere(crate::shapes::Sphere {
            center: Vec3::ZERO,
            radius: 1.0,
            inside: false,
        });
        let shapes = vec![t(0.0), t(1.0), t(2.0), sphere, t(4.0), t(5.0), t(6.0)];
        // Slots: 0-2 a leaf, 4-5 a leaf with the sphere, 8-13 a leaf of six
        // triangles (two blocks), 16 a leaf that does not start a block.
        let order = [0, 1, 2, 3, 4, 5, 6, 0, 1, 2];
        let leaves: [(usize, &[u32]); 4] = [
            (0, &order[0..3]),
            (4, &order[3..5]),
            (8, &order[4..10]),
            (17, &order[0..1]),
        ];
        let blocks = LeafBlocks::new(&shapes, 20, leaves.into_iter());
        assert_eq!(
            blocks.len(),
            3,
            "the leaf with a sphere keeps the scalar test"
        );
        assert_eq!(blocks.triangles(), 3 + 6);
        assert_eq!(blocks.of_leaf(0, 3).len(), 1);
        assert_eq!(blocks.of_leaf(8, 6).len(), 2);
        assert!(blocks.of_leaf(4, 2).is_empty());
        assert!(blocks.of_leaf(17, 1).is_empty());
        assert!(blocks.of_leaf(16, 1).is_empty());
        // The six-triangle leaf (primitives 4, 5, 6, 0 | 1, 2): block 2
        // holds its first four, block 3 the rest, in slot order.
        let down = |x: f32| Ray::new(Vec3::new(x, 0.2, 1.0), -Vec3::Z);
        let leaf = blocks.of_leaf(8, 6);
        assert_eq!(leaf[0].intersect(&down(6.2), 0.0, 9.0).mask, 0b0100);
        assert_eq!(leaf[0].intersect(&down(0.2), 0.0, 9.0).mask, 0b1000);
        assert_eq!(leaf[1].intersect(&down(2.2), 0.0, 9.0).mask, 0b0010);
        assert_eq!(leaf[1].intersect(&down(4.2), 0.0, 9.0).mask, 0);
        assert_eq!(std::mem::size_of::<Triangle4>(), 192);
        // No leaf of triangles: no blocks.
        let none = LeafBlocks::new(&shapes, 20, [(4, &order[3..4])].into_iter());
        assert_eq!(none.memory_bytes(), 0);
    }
}

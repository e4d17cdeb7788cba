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
use super::{Shape, Triangle};
use crate::math::Ray;
use wide::{f32x4, f32x8};

/// Triangles per block: a hierarchy leaf holds at most this many primitives
/// (`BuildOptions::max_leaf`), so a leaf of triangles is one block.
pub const BLOCK: usize = 4;

/// Up to four triangles, component by component. An unused lane has zero
/// edges: its determinant is 0, which no ray passes, and `lanes` masks it too.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub struct Triangle4 {
    v0: [f32x4; 3],
    e1: [f32x4; 3],
    e2: [f32x4; 3],
    n: [f32x4; 3],
    /// Bits of the lanes in use.
    lanes: u32,
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

impl Triangle4 {
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
            lanes: (1u32 << tris.len()) - 1,
        }
    }

    /// `Triangle::intersect` of `ray` with the four triangles at once.
    #[inline(always)]
    pub fn intersect(&self, ray: &Ray, t_min: f32, t_max: f32) -> BlockHits {
        let sp = f32x4::splat;
        let dir = [ray.dir.x, ray.dir.y, ray.dir.z].map(sp);
        let org = [ray.origin.x, ray.origin.y, ray.origin.z].map(sp);
        let found = intersect_lanes(dir, org, [self.v0, self.e1, self.e2, self.n], f32x4::ONE);
        let mask = self.lanes & kept_lanes!(f32x4, found, sp(t_min), sp(t_max));
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
        let mask =
            (self.lanes | self.lanes << BLOCK) & kept_lanes!(f32x8, found, f32x8::splat(t_min), hi);
        let [_, u, v, t] = found;
        let (t, u, v) = (t.to_array(), u.to_array(), v.to_array());
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
}

/// A block and the primitives in its lanes.
#[derive(Clone, Copy, Debug)]
struct LeafBlock {
    tris: Triangle4,
    prims: [u32; BLOCK],
    count: u32,
}

/// The scene's hierarchy leaves made only of triangles, each as one
/// `Triangle4`, found by the leaf's first primitive.
#[derive(Clone, Debug, Default)]
pub struct LeafTriangles {
    blocks: Vec<LeafBlock>,
    /// Per primitive: the block of the leaf it starts, or `NONE`.
    at: Vec<u32>,
}

impl LeafTriangles {
    const NONE: u32 = u32::MAX;

    /// Blocks for the `leaves` (each a slice of primitive indices into
    /// `shapes`) that hold 1 to `BLOCK` primitives, all triangles.
    pub fn new<'a>(shapes: &[Shape], leaves: impl Iterator<Item = &'a [u32]>) -> LeafTriangles {
        let mut out = LeafTriangles {
            blocks: Vec::new(),
            at: vec![Self::NONE; shapes.len()],
        };
        for leaf in leaves {
            if leaf.is_empty() || leaf.len() > BLOCK {
                continue;
            }
            let tris: arrayvec::ArrayVec<&Triangle, BLOCK> = leaf
                .iter()
                .filter_map(|&p| match shapes.get(p as usize) {
                    Some(Shape::Triangle(t)) => Some(t),
                    _ => None,
                })
                .collect();
            if tris.len() != leaf.len() || out.at[leaf[0] as usize] != Self::NONE {
                continue;
            }
            let mut prims = [u32::MAX; BLOCK];
            prims[..leaf.len()].copy_from_slice(leaf);
            out.at[leaf[0] as usize] = out.blocks.len() as u32;
            out.blocks.push(LeafBlock {
                tris: Triangle4::new(&tris),
                prims,
                count: leaf.len() as u32,
            });
        }
        out
    }

    /// The block holding exactly the primitives `prims` (in this order), if any.
    #[inline(always)]
    pub fn block(&self, prims: &[u32]) -> Option<&Triangle4> {
        let first = *prims.first()?;
        let b = *self.at.get(first as usize)?;
        if b == Self::NONE {
            return None;
        }
        let block = &self.blocks[b as usize];
        (block.count as usize == prims.len() && block.prims[..prims.len()] == *prims)
            .then_some(&block.tris)
    }

    /// Number of blocks.
    pub fn len(&self) -> usize {
        self.blocks.len()
    }

    pub fn is_empty(&self) -> bool {
        self.blocks.is_empty()
    }

    /// Memory held, in bytes.
    pub fn memory_bytes(&self) -> usize {
        self.blocks.len() * std::mem::size_of::<LeafBlock>() + self.at.len() * 4
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

    #[test]
    fn a_block_is_found_only_for_its_own_leaf() {
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
        let shapes = vec![t(0.0), t(1.0), t(2.0), sphere, t(4.0), t(5.0)];
        let leaves: [&[u32]; 3] = [&[0, 1, 2], &[3, 4], &[5]];
        let blocks = LeafTriangles::new(&shapes, leaves.into_iter());
        assert_eq!(
            blocks.len(),
            2,
            "the leaf with a sphere keeps the scalar test"
        );
        assert!(blocks.block(&[0, 1, 2]).is_some());
        assert!(blocks.block(&[5]).is_some());
        assert!(blocks.block(&[3, 4]).is_none());
        // Another tree's leaf that starts at the same primitive.
        assert!(blocks.block(&[0, 1]).is_none());
        assert!(blocks.block(&[0, 2, 1]).is_none());
        assert!(blocks.block(&[1, 2]).is_none());
    }
}

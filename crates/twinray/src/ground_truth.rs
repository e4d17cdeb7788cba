//! The ground truth of a view, at every pixel centre, for stereo matching
//! and depth estimation: depth, disparity to the neighbouring view, whether
//! the neighbour sees the point (occlusion) and whether it falls inside the
//! neighbour's frame, and the second layer of mirrors and glass.
//!
//! * `depth`: as the `Z` channel (`output/depth_channels.rs`): the camera
//!   depth, along the view direction, of the surface the renderer's ray
//!   through the pixel centre meets; `+inf` where it meets nothing.
//! * `disparity`: in pixels, with SceneFlow's sign: positive for a point at a
//!   finite depth seen by parallel cameras. The neighbour is the view to the
//!   right (the last view's is the one to its left); a point at column `x`
//!   of a view lies at `x − d` in the neighbour to its right, at `x + d` in
//!   the neighbour to its left. With a convergence shift, `d = f·b/z −
//!   f·b/C` up to the whole-pixel rounding of the shift: negative behind the
//!   zero-parallax plane `C`. Where nothing is hit, the disparity of infinity.
//! * `occluded`: the point is hidden in the neighbour: the ray from the
//!   neighbour's eye to it meets another surface first (traced, not inferred
//!   from depth maps); where nothing is hit, the neighbour's ray along the
//!   same direction (to the same point at infinity) meets a surface.
//! * `out_of_frame`: the point's column in the neighbour lies outside its
//!   image (or the point is behind the neighbour's eye).
//! * `layer2_depth`, `layer2_disparity`: where the surface hit is a mirror
//!   or glass (its mirror weight or `T` at least [`SPECULAR`]), what it shows: the ray is
//!   followed as the renderer follows it (refracted where the surface
//!   transmits, else reflected; total internal reflection reflects) through
//!   every further mirror or glass surface, up to the trace's depth limit,
//!   and the virtual point lies along the eye ray at the path's whole length:
//!   its depth and disparity. For a flat mirror that is exactly where the
//!   neighbour sees the mirrored point; through glass it is the path length
//!   unrefracted. NaN elsewhere.
//!
//! A single view has no neighbour: disparity 0, both masks false, and the
//! second layer's depth only.

use rayon::prelude::*;

use crate::bvh::{
    AnyHit, AnyHitTest, Packet, PacketHits, SegmentPacket, TraversalStats, EYE_PACKET,
};
use crate::math::{reflect, refract, Ray};
use crate::render::NearestShape;
use crate::rig::depth_pass::{nearest_hit, nearest_surface};
use crate::rig::{pair_disparity, Camera, Rig, View};
use crate::shading::offset_point;
use crate::shapes::{Shape, SurfaceHit, Triangle4};
use crate::world::World;

/// Relative distance short of the point by which the neighbour's ray must
/// meet another surface for the point to count as hidden: the rounding of a
/// hit point, with room to spare, not a visible gap.
const OCCLUSION_MARGIN: f32 = 1e-4;

/// The mirror or transmission weight from which a surface shows what lies
/// beyond it more than its own colour: a mirror or glass. (NFF's `Ks` is
/// both the highlight and the mirror weight; the SPD's 0.2 of most
/// surfaces is a gloss, not a mirror.)
pub const SPECULAR: f32 = 0.5;

/// Pixel centres of a row traced together: their eye rays in one descent,
/// the neighbour's rays to their points in another.
const RUN: usize = EYE_PACKET;

/// How far past an occlusion test's end the hierarchy's boxes are entered:
/// more than the traversals' culling slack, so that every primitive the
/// nearest-hit search could find short of the end is tested (the primitive
/// test itself stops at the end).
const SEGMENT_SLACK: f32 = 1.0 + 1.0 / 1024.0;

/// One view's ground truth, row-major like its image.
#[derive(Clone, Debug, PartialEq)]
pub struct GroundTruth {
    pub width: u32,
    pub height: u32,
    pub depth: Vec<f32>,
    pub disparity: Vec<f32>,
    pub occluded: Vec<bool>,
    pub out_of_frame: Vec<bool>,
    pub layer2_depth: Vec<f32>,
    pub layer2_disparity: Vec<f32>,
}

/// What one pixel centre gives.
#[derive(Clone, Copy, Debug)]
struct Pixel {
    depth: f32,
    disparity: f32,
    occluded: bool,
    out_of_frame: bool,
    layer2_depth: f32,
    layer2_disparity: f32,
}

/// The neighbour of a view and the sign that turns [`pair_disparity`]
/// (the point's column there minus its column here) into SceneFlow's.
#[derive(Clone, Copy, Debug)]
struct Neighbour {
    view: View,
    sign: f64,
}

impl GroundTruth {
    /// View `view` of `rig`, with mirror and glass paths of up to
    /// `max_depth` rays (the eye ray is the first), on the calling thread's
    /// rayon pool.
    pub fn measure(
        world: &World,
        camera: &Camera,
        rig: &Rig,
        view: usize,
        max_depth: u32,
    ) -> GroundTruth {
        let probe = Probe::new(world, camera.hither);
        measure_counted(&probe, camera, rig, view, max_depth).0
    }

    /// Every view of `rig`.
    pub fn measure_all(
        world: &World,
        camera: &Camera,
        rig: &Rig,
        max_depth: u32,
    ) -> Vec<GroundTruth> {
        (0..rig.views.len())
            .map(|v| GroundTruth::measure(world, camera, rig, v, max_depth))
            .collect()
    }
}

/// `GroundTruth::measure` with `probe`, and the traversals' work.
fn measure_counted(
    probe: &Probe,
    camera: &Camera,
    rig: &Rig,
    view: usize,
    max_depth: u32,
) -> (GroundTruth, TraversalStats) {
    let n = rig.views.len();
    let here = rig.views[view.min(n.saturating_sub(1))];
    let neighbour = (n >= 2).then(|| {
        let other = if view + 1 < n { view + 1 } else { view - 1 };
        let there = rig.views[other];
        Neighbour {
            view: there,
            sign: if there.offset > here.offset {
                -1.0
            } else {
                1.0
            },
        }
    });
    let (w, h) = (camera.width, camera.height);
    let rows: Vec<(Vec<Pixel>, TraversalStats)> = (0..h)
        .into_par_iter()
        .map(|y| {
            let mut stats = TraversalStats::default();
            let mut row = Vec::with_capacity(w as usize);
            for x in (0..w).step_by(RUN) {
                let count = (w - x).min(RUN as u32) as usize;
                let run = Run {
                    x,
                    y,
                    count,
                    here,
                    neighbour,
                };
                row.extend(run.pixels(probe, camera, max_depth, &mut stats));
            }
            (row, stats)
        })
        .collect();
    let mut stats = TraversalStats::default();
    let mut pixels = Vec::with_capacity(w as usize * h as usize);
    for (row, s) in rows {
        pixels.extend(row);
        stats += s;
    }
    let truth = GroundTruth {
        width: w,
        height: h,
        depth: pixels.iter().map(|p| p.depth).collect(),
        disparity: pixels.iter().map(|p| p.disparity).collect(),
        occluded: pixels.iter().map(|p| p.occluded).collect(),
        out_of_frame: pixels.iter().map(|p| p.out_of_frame).collect(),
        layer2_depth: pixels.iter().map(|p| p.layer2_depth).collect(),
        layer2_disparity: pixels.iter().map(|p| p.layer2_disparity).collect(),
    };
    (truth, stats)
}

/// Up to [`RUN`] neighbouring pixel centres of a row: `count` from column `x`.
struct Run {
    x: u32,
    y: u32,
    count: usize,
    here: View,
    neighbour: Option<Neighbour>,
}

impl Run {
    /// The ground truth at each of the run's pixel centres.
    fn pixels(
        &self,
        probe: &Probe,
        camera: &Camera,
        max_depth: u32,
        stats: &mut TraversalStats,
    ) -> Vec<Pixel> {
        let here = self.here;
        let origin = camera.eye_at(here.offset);
        let rays: [Ray; RUN] = std::array::from_fn(|l| {
            let x = self.x + l.min(self.count - 1) as u32;
            let column = (x as i64 + here.shift as i64) as f32;
            Ray::new(origin, camera.direction(column, self.y as f32))
        });
        let firsts = probe.nearest(&rays, self.count, stats);
        // Where the neighbour looks from, and the rays it sends to the points
        // (the occlusion tests, answered together below).
        let eye = self.neighbour.map(|nb| camera.eye_at(nb.view.offset));
        let mut tests = SegmentPacket::<RUN>::empty();
        let mut pixels = Vec::with_capacity(self.count);
        for (l, (ray, first)) in rays.iter().zip(firsts).take(self.count).enumerate() {
            let cosine = ray.dir.dot(camera.forward);
            let depth = first.map_or(f32::INFINITY, |(_, hit)| hit.t * cosine);
            let layer2_depth = match first {
                Some((prim, hit)) => second_layer(probe, ray, prim, hit, max_depth, stats)
                    .map_or(f32::NAN, |length| length * cosine),
                None => f32::NAN,
            };
            let (Some(nb), Some(eye)) = (self.neighbour, eye) else {
                pixels.push(Pixel {
                    depth,
                    disparity: 0.0,
                    occluded: false,
                    out_of_frame: false,
                    layer2_depth,
                    layer2_disparity: if layer2_depth.is_nan() { f32::NAN } else { 0.0 },
                });
                continue;
            };
            let scene_flow = |z: f32| nb.sign * pair_disparity(camera, here, nb.view, f64::from(z));
            let disparity = scene_flow(depth);
            // The point's column in the neighbour: x − d to the right, x + d to the left.
            let there = f64::from(self.x + l as u32) + nb.sign * disparity;
            let mut out_of_frame = !(-0.5..f64::from(camera.width) - 0.5).contains(&there);
            // The point is hidden where the neighbour's ray to it meets a
            // surface before it; the background, at infinity, where its ray
            // along the same direction meets one.
            let test = match first {
                Some((_, hit)) => {
                    let point = ray.at(hit.t);
                    if camera.depth_of(point, nb.view.offset) <= camera.hither {
                        out_of_frame = true;
                        None
                    } else {
                        let to = point - eye;
                        let distance = to.length();
                        Some((to / distance, distance * (1.0 - OCCLUSION_MARGIN)))
                    }
                }
                None => Some((ray.dir, f32::INFINITY)),
            };
            if let Some((dir, end)) = test {
                tests.origins[l] = eye;
                tests.dirs[l] = dir;
                tests.t_max[l] = end;
                tests.mask |= 1 << l;
            }
            pixels.push(Pixel {
                depth,
                disparity: disparity as f32,
                occluded: false,
                out_of_frame,
                layer2_depth,
                layer2_disparity: if layer2_depth.is_nan() {
                    f32::NAN
                } else {
                    scene_flow(layer2_depth) as f32
                },
            });
        }
        let hidden = probe.blocked(&tests, stats);
        for (l, p) in pixels.iter_mut().enumerate() {
            p.occluded = hidden & (1 << l) != 0;
        }
        pixels
    }
}

/// The two questions the ground truth asks of the world: the surface each
/// of a run's eye rays shows, and whether each of a run's segments meets a
/// surface. In a world without cut-outs or a cut, a run's rays go down the
/// hierarchy together, with leaves of triangles tested as blocks, and a
/// segment stops at its first hit; their answers are bit for bit those of
/// one ray at a time with the depth pass's nearest-hit search (every
/// primitive and block test does the same arithmetic, the culling is
/// conservative, and a primitive met before a segment's end is exactly one
/// whose nearest hit lies before it), which the other worlds use.
struct Probe<'a> {
    world: &'a World,
    hither: f32,
    together: bool,
}

impl<'a> Probe<'a> {
    fn new(world: &'a World, hither: f32) -> Probe<'a> {
        Probe {
            world,
            hither,
            together: !world.has_alpha && world.far.is_none(),
        }
    }

    /// The primitive and hit each of the first `count` rays of `rays` shows
    /// (the depth pass's `nearest_surface` from the hither distance).
    fn nearest(
        &self,
        rays: &[Ray; RUN],
        count: usize,
        stats: &mut TraversalStats,
    ) -> [Option<(u32, SurfaceHit)>; RUN] {
        if self.together {
            let packet = Packet::<RUN> {
                origins: rays.map(|r| r.origin),
                dirs: rays.map(|r| r.dir),
                t_min: self.hither,
                t_max: [f32::INFINITY; RUN],
                mask: (1u32 << count) - 1,
            };
            let test = NearestShape::new(&self.world.scene.shapes, &packet);
            // `None`: the rays' direction signs differ; each goes alone.
            if let Some(hits) = self.world.bvh.closest_packet8(&packet, stats, test) {
                return std::array::from_fn(|l| {
                    (l < count && hits.has_hit(l)).then(|| (hits.prim[l], hits.hit[l]))
                });
            }
        }
        std::array::from_fn(|l| {
            (l < count)
                .then(|| self.nearest_one(&rays[l], self.hither, stats))
                .flatten()
        })
    }

    /// The primitive and hit `ray` shows beyond `t_min` (the depth pass's
    /// `nearest_surface`).
    fn nearest_one(
        &self,
        ray: &Ray,
        t_min: f32,
        stats: &mut TraversalStats,
    ) -> Option<(u32, SurfaceHit)> {
        if !self.together {
            return nearest_surface(self.world, ray, t_min, stats);
        }
        let packet = Packet::<1> {
            origins: [ray.origin],
            dirs: [ray.dir],
            t_min,
            t_max: [f32::INFINITY],
            mask: 1,
        };
        let test = NearestShape::new(&self.world.scene.shapes, &packet);
        let (prim, hit) = self.world.bvh.closest_ray(&packet, stats, test);
        (prim != PacketHits::<1>::NO_HIT).then_some((prim, hit))
    }

    /// The lanes of `tests` whose segment, from beyond the hither distance
    /// to short of its end, meets a surface that the depth pass's nearest-hit
    /// search would find there.
    fn blocked(&self, tests: &SegmentPacket<RUN>, stats: &mut TraversalStats) -> u32 {
        if !self.together {
            let mut hidden = 0;
            for l in (0..RUN).filter(|&l| tests.mask & (1 << l) != 0) {
                let ray = Ray::new(tests.origins[l], tests.dirs[l]);
                if nearest_hit(self.world, &ray, self.hither, stats) < tests.t_max[l] {
                    hidden |= 1 << l;
                }
            }
            return hidden;
        }
        let mut entered = *tests;
        entered.t_max = tests.t_max.map(|end| end * SEGMENT_SLACK);
        let mut test = SegmentTest {
            shapes: &self.world.scene.shapes,
            tests,
            hither: self.hither,
            met: 0,
        };
        self.world.bvh.occlusion(&entered, stats, &mut test);
        test.met
    }
}

/// The occlusion tests' primitive tests: a lane stops at the first
/// primitive it meets between the hither distance and its end.
struct SegmentTest<'a> {
    shapes: &'a [Shape],
    tests: &'a SegmentPacket<RUN>,
    hither: f32,
    /// The lanes stopped.
    met: u32,
}

impl SegmentTest<'_> {
    #[inline(always)]
    fn ray(&self, lane: usize) -> Ray {
        Ray::new(self.tests.origins[lane], self.tests.dirs[lane])
    }

    #[inline(always)]
    fn stop_if(&mut self, met: bool, lane: usize) -> AnyHit {
        if met {
            self.met |= 1 << lane;
            AnyHit::Stop
        } else {
            AnyHit::Continue
        }
    }
}

impl AnyHitTest for SegmentTest<'_> {
    #[inline(always)]
    fn test(&mut self, prim: u32, lane: usize) -> AnyHit {
        let end = self.tests.t_max[lane];
        let met = self.shapes[prim as usize]
            .intersect(&self.ray(lane), self.hither, end)
            .is_some();
        self.stop_if(met, lane)
    }

    #[inline(always)]
    fn test_block(&mut self, block: &Triangle4, prims: &[u32], lane: usize) -> Option<AnyHit> {
        let hits = block.intersect(&self.ray(lane), self.hither, self.tests.t_max[lane]);
        // Lanes past the block's primitives are not the leaf's.
        let met = hits.mask & ((1u32 << prims.len()) - 1) != 0;
        Some(self.stop_if(met, lane))
    }
}

/// The length of the path the renderer's ray follows from the eye through
/// mirror and glass surfaces, starting with `hit` on `prim`, to the first
/// surface that is neither (or into the background: infinity); `None` where
/// the first surface is not a mirror or glass.
fn second_layer(
    probe: &Probe,
    eye_ray: &Ray,
    prim: u32,
    hit: SurfaceHit,
    max_depth: u32,
    stats: &mut TraversalStats,
) -> Option<f32> {
    let world = probe.world;
    let specular = |prim: u32| {
        let m = world.material_of(prim);
        m.mirror >= SPECULAR || m.t >= SPECULAR
    };
    if !specular(prim) {
        return None;
    }
    let (mut ray, mut prim, mut hit) = (*eye_ray, prim, hit);
    let mut length = hit.t;
    // The eye ray is the first of `max_depth`; each bounce adds one.
    for _ in 1..max_depth {
        if !specular(prim) {
            break;
        }
        ray = next_ray(world, prim, &ray, &hit);
        match probe.nearest_one(&ray, 0.0, stats) {
            None => return Some(f32::INFINITY),
            Some((p, h)) => {
                length += h.t;
                (prim, hit) = (p, h);
            }
        }
    }
    Some(length)
}

/// The secondary ray the renderer follows from `hit` along `ray` on `prim`
/// (`render/tracer`): refracted where the surface transmits (reflected on
/// total internal reflection), else reflected, leaving the surface by the
/// renderer's margin.
fn next_ray(world: &World, prim: u32, ray: &Ray, hit: &SurfaceHit) -> Ray {
    let scene = &world.scene;
    let point = ray.at(hit.t);
    let d = ray.dir;
    let surface = scene.surface_at(prim as usize, hit, point);
    let material = surface.material;
    let facing = if surface.normal.dot(d) < 0.0 {
        surface.normal
    } else {
        -surface.normal
    };
    let unbent = surface.offset_normal;
    let off = if unbent.dot(d) < 0.0 { unbent } else { -unbent };
    if material.t > 0.0 {
        let entering = scene.shapes[prim as usize].met_from_front(point, d);
        if let Some(dir) = refract(d, facing, material.eta(entering)) {
            return Ray::new(offset_point(point, -off, hit.t), dir);
        }
    }
    Ray::new(offset_point(point, off, hit.t), reflect(d, facing))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Triangles, spheres and cones strewn between the camera and a wall
    /// (mirrors and glass among them), and a sphere just past the hither
    /// distance: objects hide one another from either eye, in rows whose
    /// rays change direction sign at the image centre.
    fn clutter() -> String {
        let mut rng = fastrand::Rng::with_seed(11);
        let mut text = String::from(
            "b 0.1 0.1 0.1\nv\nfrom 0 -8 0\nat 0 0 0\nup 0 0 1\nangle 50\nhither 0.3\n\
             resolution 64 40\nl 3 -6 5\nf 0.8 0.7 0.6 0.8 0.1 20 0 1\n\
             p 4\n-20 6 -20\n20 6 -20\n20 6 20\n-20 6 20\n",
        );
        let mut r = |lo: f32, hi: f32| lo + (hi - lo) * rng.f32();
        for k in 0..60 {
            let (x, y, z) = (r(-4.0, 4.0), r(-5.0, 5.0), r(-2.5, 2.5));
            text += match k % 6 {
                0 => "f 0.9 0.9 0.9 0.05 0.9 200 0 1\n",
                1 => "f 0.9 0.95 1 0.05 0.1 200 0.8 1.5\n",
                _ => "f 0.4 0.6 0.3 0.8 0.1 20 0 1\n",
            };
            text += &match k % 3 {
                0 => format!("s {x} {y} {z} {}\n", r(0.1, 0.6)),
                1 => format!(
                    "p 3\n{x} {y} {z}\n{} {} {}\n{} {} {}\n",
                    x + r(-1.0, 1.0),
                    y + r(-1.0, 1.0),
                    z + r(-1.0, 1.0),
                    x + r(-1.0, 1.0),
                    y + r(-1.0, 1.0),
                    z + r(-1.0, 1.0)
                ),
                _ => format!(
                    "c\n{x} {y} {z} {}\n{} {} {} {}\n",
                    r(0.1, 0.4),
                    x + r(-0.5, 0.5),
                    y + r(-0.5, 0.5),
                    z + r(0.5, 1.5),
                    r(0.0, 0.3)
                ),
            };
        }
        // Beside the left eye, closer than the hither distance of the camera,
        // but in the way of the right eye's rays to the far left.
        text += "f 0.5 0.5 0.5 0.8 0 1 0 1\ns -0.35 -7.9 0 0.05\n";
        text
    }

    /// The ground truth of every view of `rig`, by runs of rays and
    /// segments that stop at their first hit, is bit for bit the one of a
    /// ray at a time with the nearest-hit search; the runs do less work.
    fn same_as_one_ray_at_a_time(world: &World, camera: &Camera, rig: &Rig) {
        let together = Probe::new(world, camera.hither);
        assert!(together.together);
        let alone = Probe {
            together: false,
            ..Probe::new(world, camera.hither)
        };
        // The pixels where two layers differ (bit for bit, NaN included).
        fn differ<T: Copy>(a: &[T], b: &[T], key: impl Fn(T) -> u32) -> Vec<usize> {
            (0..a.len()).filter(|&i| key(a[i]) != key(b[i])).collect()
        }
        let bits = |x: f32| x.to_bits();
        for view in 0..rig.views.len() {
            let (a, sa) = measure_counted(&together, camera, rig, view, 5);
            let (b, sb) = measure_counted(&alone, camera, rig, view, 5);
            for (name, d) in [
                ("depth", differ(&a.depth, &b.depth, bits)),
                ("disparity", differ(&a.disparity, &b.disparity, bits)),
                ("occluded", differ(&a.occluded, &b.occluded, u32::from)),
                (
                    "out of frame",
                    differ(&a.out_of_frame, &b.out_of_frame, u32::from),
                ),
                (
                    "layer 2 depth",
                    differ(&a.layer2_depth, &b.layer2_depth, bits),
                ),
                (
                    "layer 2 disparity",
                    differ(&a.layer2_disparity, &b.layer2_disparity, bits),
                ),
            ] {
                assert!(
                    d.is_empty(),
                    "{name} differs at {} pixels of view {view}, first {:?}",
                    d.len(),
                    d.first()
                );
            }
            assert!(
                sa.nodes * 2 < sb.nodes,
                "nodes visited: {} by runs, {} a ray at a time",
                sa.nodes,
                sb.nodes
            );
            let hidden = a.occluded.iter().filter(|&&o| o).count();
            assert!(
                hidden > 0 && hidden < a.occluded.len() / 2,
                "{hidden} pixels hidden in view {view}"
            );
        }
    }

    #[test]
    fn runs_of_pixels_give_the_truth_of_one_ray_at_a_time() {
        let world = World::from_nff_text(&clutter());
        let camera = Camera::new(&world.scene.viewpoint, 64, 40);
        for (views, interaxial, convergence) in
            [(2, 0.7, None), (2, 0.4, Some(6.0)), (3, 0.5, Some(9.0))]
        {
            let rig = Rig::multi_view(&camera, views, interaxial, convergence).expect("rig");
            same_as_one_ray_at_a_time(&world, &camera, &rig);
        }
        let example = World::from_nff_text(include_str!("../../../scenes/example.nff"));
        let camera = Camera::new(&example.scene.viewpoint, 80, 60);
        let rig = Rig::stereo(&camera, 0.3, Some(7.0)).expect("rig");
        same_as_one_ray_at_a_time(&example, &camera, &rig);
    }
}

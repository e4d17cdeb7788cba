//! The depth pass: how far the visible surfaces are, from eye rays alone.
//!
//! For one view of a rig, the nearest hit along the eye ray through a grid of
//! pixel centres, as a camera depth (along the view direction, the `Z` of the
//! parallax formula). No shading, no secondary rays: it costs a fraction of the
//! render. The disparity report, the automatic rig and the window-violation
//! check read it at a reduced resolution (every `stride`-th pixel, the edge
//! columns always included); the `Z` output reads it at every pixel.
//!
//! The rays are the renderer's: view `v`'s pixel `x` looks along camera column
//! `x + shift` from `Camera::eye_at(offset)`, `t > hither`, and the nearest hit
//! comes from the hierarchy's own traversal (both parts of a cut world), so the
//! depth is that of the surface the render shows at that pixel centre.

use rayon::prelude::*;
use serde::Serialize;

use super::{Camera, Rig, View};
use crate::bvh::{Bvh, Packet, TraversalStats};
use crate::math::Ray;
use crate::shapes::SurfaceHit;
use crate::world::World;

/// Camera depths of one view at a grid of its pixel centres.
#[derive(Clone, Debug, PartialEq)]
pub struct DepthPass {
    /// The view sampled.
    pub view: View,
    /// Image columns sampled, increasing; the first and last columns always.
    pub columns: Vec<u32>,
    /// Image rows sampled, increasing; the first and last rows always.
    pub rows: Vec<u32>,
    /// Depth along the view direction per sample, row-major over
    /// `rows` x `columns`; `f32::INFINITY` where the ray hits nothing.
    pub depth: Vec<f32>,
}

impl DepthPass {
    /// The depth at sample (`i`, `j`): column `columns[i]`, row `rows[j]`.
    #[inline]
    pub fn at(&self, i: usize, j: usize) -> f32 {
        self.depth[j * self.columns.len() + i]
    }

    /// Every sample as (image column, image row, depth).
    pub fn samples(&self) -> impl Iterator<Item = (u32, u32, f32)> + '_ {
        self.rows.iter().enumerate().flat_map(move |(j, &y)| {
            self.columns
                .iter()
                .enumerate()
                .map(move |(i, &x)| (x, y, self.at(i, j)))
        })
    }

    /// The depths of the samples that hit something.
    pub fn finite_depths(&self) -> impl Iterator<Item = f32> + '_ {
        self.depth.iter().copied().filter(|d| d.is_finite())
    }
}

/// `0, stride, 2·stride, …` below `len`, and `len − 1`: every `stride`-th
/// position with the last one kept (the frame's far edge matters to the
/// window-violation check).
pub fn sample_positions(len: u32, stride: u32) -> Vec<u32> {
    let stride = stride.max(1) as usize;
    let mut out: Vec<u32> = (0..len).step_by(stride).collect();
    if len > 0 && out.last() != Some(&(len - 1)) {
        out.push(len - 1);
    }
    out
}

/// The stride that samples at most `max_columns` columns of a `width`-pixel
/// image (plus the last column).
pub fn stride_for(width: u32, max_columns: u32) -> u32 {
    width.div_ceil(max_columns.max(1)).max(1)
}

/// The depth pass of `view` of `camera`: every `stride`-th pixel centre in
/// both directions (1 = every pixel).
pub fn depth_pass(world: &World, camera: &Camera, view: View, stride: u32) -> DepthPass {
    let columns = sample_positions(camera.width, stride);
    let rows = sample_positions(camera.height, stride);
    let origin = camera.eye_at(view.offset);
    let depth: Vec<f32> = rows
        .par_iter()
        .flat_map_iter(|&y| {
            let mut stats = TraversalStats::default();
            columns
                .iter()
                .map(|&x| {
                    let column = (x as i64 + view.shift as i64) as f32;
                    let ray = Ray::new(origin, camera.direction(column, y as f32));
                    let t = nearest_hit(world, &ray, camera.hither, &mut stats);
                    t * ray.dir.dot(camera.forward)
                })
                .collect::<Vec<_>>()
        })
        .collect();
    DepthPass {
        view,
        columns,
        rows,
        depth,
    }
}

/// The distance to the nearest surface along `ray` beyond `t_min`, in the
/// whole world (near hierarchy and, with a cut, the far one), passing through
/// the cut-away parts of MASK materials as the renderer's rays do;
/// `f32::INFINITY` if there is none.
pub fn nearest_hit(world: &World, ray: &Ray, t_min: f32, stats: &mut TraversalStats) -> f32 {
    nearest_surface(world, ray, t_min, stats).map_or(f32::INFINITY, |(_, hit)| hit.t)
}

/// The primitive and hit of [`nearest_hit`]: the surface the renderer's ray
/// shades (past the last cut-out layer it reaches, the hit there).
pub fn nearest_surface(
    world: &World,
    ray: &Ray,
    t_min: f32,
    stats: &mut TraversalStats,
) -> Option<(u32, SurfaceHit)> {
    let mut from = t_min;
    let mut last = None;
    for _ in 0..=crate::world::MAX_CUTOUT_LAYERS {
        let mut nearest = nearest_in(world, &world.bvh, ray, from, f32::INFINITY, stats);
        if let Some(far) = &world.far {
            let beyond = nearest_in(
                world,
                far,
                ray,
                from,
                nearest.map_or(f32::INFINITY, |(_, h)| h.t),
                stats,
            );
            nearest = beyond.or(nearest);
        }
        match nearest {
            None => return None,
            Some((prim, hit)) if world.has_alpha && world.scene.cut_away(prim as usize, &hit) => {
                from = hit.t;
                last = nearest;
            }
            found => return found,
        }
    }
    // As the renderer's rays, stop at the last layer reached.
    last
}

/// The nearest primitive and hit along `ray` in `bvh` within (`t_min`, `t_max`).
fn nearest_in(
    world: &World,
    bvh: &Bvh,
    ray: &Ray,
    t_min: f32,
    t_max: f32,
    stats: &mut TraversalStats,
) -> Option<(u32, SurfaceHit)> {
    let packet = Packet::<1> {
        origins: [ray.origin],
        dirs: [ray.dir],
        t_min,
        t_max: [t_max],
        mask: 1,
    };
    let shapes = &world.scene.shapes;
    let hits = bvh.closest(&packet, stats, |prim: u32, _lane: usize, t_max: f32| {
        shapes[prim as usize].intersect(ray, t_min, t_max)
    });
    hits.has_hit(0).then(|| (hits.prim[0], hits.hit[0]))
}

/// Percentiles of the visible depths (scene units, along the view direction).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct DepthStats {
    pub nearest: f32,
    pub p1: f32,
    pub p5: f32,
    pub median: f32,
    pub p95: f32,
    pub p99: f32,
    pub farthest: f32,
    /// Fraction of the samples that hit a surface (the rest see the background).
    pub hit_fraction: f64,
}

impl DepthStats {
    /// The statistics of `depths` (infinite values are misses); `None` when
    /// nothing was hit.
    pub fn of(depths: impl IntoIterator<Item = f32>) -> Option<DepthStats> {
        let mut total = 0usize;
        let mut hit: Vec<f32> = Vec::new();
        for d in depths {
            total += 1;
            if d.is_finite() {
                hit.push(d);
            }
        }
        if hit.is_empty() {
            return None;
        }
        hit.sort_unstable_by(f32::total_cmp);
        // Nearest rank: the smallest value with at least p % of the samples at or below it.
        let rank = |p: f64| {
            let k = (p / 100.0 * hit.len() as f64).ceil() as usize;
            hit[k.clamp(1, hit.len()) - 1]
        };
        Some(DepthStats {
            nearest: hit[0],
            p1: rank(1.0),
            p5: rank(5.0),
            median: rank(50.0),
            p95: rank(95.0),
            p99: rank(99.0),
            farthest: hit[hit.len() - 1],
            hit_fraction: hit.len() as f64 / total as f64,
        })
    }
}

/// At most this many columns are sampled by the depth passes of the rig's
/// choice and of the report (`depth::stride_for`; every 4th pixel at 512 to
/// 640 wide): at most 5 passes of a sixteenth of a view's eye rays each.
pub const REPORT_COLUMNS: u32 = 160;

/// The nearest and farthest visible depths (`far` may be infinite).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct DepthRange {
    pub near: f64,
    pub far: f64,
}

impl DepthRange {
    /// The range of the finite values of `depths`; `None` if there are none.
    pub fn of(depths: impl IntoIterator<Item = f32>) -> Option<DepthRange> {
        let mut range: Option<DepthRange> = None;
        for d in depths.into_iter().filter(|d| d.is_finite() && *d > 0.0) {
            let d = f64::from(d);
            range = Some(match range {
                None => DepthRange { near: d, far: d },
                Some(r) => DepthRange {
                    near: r.near.min(d),
                    far: r.far.max(d),
                },
            });
        }
        range
    }

    /// The smallest range holding both.
    pub fn union(self, o: DepthRange) -> DepthRange {
        DepthRange {
            near: self.near.min(o.near),
            far: self.far.max(o.far),
        }
    }
}

/// The depth passes of a rig's leftmost and rightmost views.
#[derive(Clone, Debug, PartialEq)]
pub struct OuterPasses {
    pub left: DepthPass,
    pub right: DepthPass,
    pub stride: u32,
}

impl OuterPasses {
    /// Runs both passes (every `stride`-th pixel).
    pub fn measure(world: &World, camera: &Camera, rig: &Rig, stride: u32) -> OuterPasses {
        let first = rig.views.first().copied().unwrap_or(View {
            offset: 0.0,
            shift: 0,
        });
        let last = rig.views.last().copied().unwrap_or(first);
        OuterPasses {
            left: depth_pass(world, camera, first, stride),
            right: depth_pass(world, camera, last, stride),
            stride,
        }
    }

    /// The visible depth range of both views (`None`: nothing visible).
    pub fn range(&self) -> Option<DepthRange> {
        DepthRange::of(self.left.finite_depths().chain(self.right.finite_depths()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;
    use crate::scene::{Scene, Viewpoint};

    #[test]
    fn positions_keep_both_edges() {
        assert_eq!(sample_positions(10, 3), vec![0, 3, 6, 9]);
        assert_eq!(sample_positions(11, 3), vec![0, 3, 6, 9, 10]);
        assert_eq!(sample_positions(5, 1), vec![0, 1, 2, 3, 4]);
        assert_eq!(sample_positions(1, 4), vec![0]);
        assert!(sample_positions(0, 4).is_empty());
        assert_eq!(stride_for(640, 256), 3);
        assert_eq!(stride_for(256, 256), 1);
        assert_eq!(stride_for(10, 0), 10);
    }

    #[test]
    fn percentiles_by_nearest_rank() {
        let depths: Vec<f32> = (1..=100)
            .map(|d| d as f32)
            .chain([f32::INFINITY; 100])
            .collect();
        let s = DepthStats::of(depths).unwrap();
        assert_eq!((s.nearest, s.p1, s.p5, s.median), (1.0, 1.0, 5.0, 50.0));
        assert_eq!((s.p95, s.p99, s.farthest), (95.0, 99.0, 100.0));
        assert_eq!(s.hit_fraction, 0.5);
        assert!(DepthStats::of([f32::INFINITY]).is_none());
    }

    /// An empty scene whose camera at the origin looks along +y, z up.
    fn looking_along_y(width: u32, height: u32) -> Scene {
        let mut scene = Scene::new();
        scene.viewpoint = Viewpoint {
            from: Vec3::ZERO,
            at: Vec3::Y,
            up: Vec3::Z,
            angle_deg: 60.0,
            angle_span: Default::default(),
            hither: 0.0,
            width,
            height,
        };
        scene
    }

    /// A MASK screen at distance 3 in front of a wall at 5: where its alpha is
    /// under the cut-off the depth pass sees through it, as the renderer's
    /// rays do; where it is over, the screen is what is nearest.
    #[test]
    fn the_depth_pass_sees_through_cut_away_parts() {
        let depth_with_screen = |alpha: f32| {
            let mut scene = looking_along_y(5, 5);
            let plane = |y: f32| {
                [(-50.0, -50.0), (50.0, -50.0), (50.0, 50.0), (-50.0, 50.0)]
                    .map(|(x, z)| Vec3::new(x, y, z))
            };
            scene.add_polygon(&plane(5.0), "wall");
            scene.add_material(crate::scene::Material {
                alpha_mode: crate::surface_maps::AlphaMode::Mask { cutoff: 0.5 },
                alpha,
                ..Default::default()
            });
            scene.add_polygon(&plane(3.0), "screen");
            let world = World::new(scene);
            let cam = Camera::new(&world.scene.viewpoint, 5, 5);
            let view = View {
                offset: 0.0,
                shift: 0,
            };
            let pass = depth_pass(&world, &cam, view, 1);
            pass.samples().map(|(_, _, d)| d).collect::<Vec<f32>>()
        };
        for d in depth_with_screen(0.2) {
            assert!((d - 5.0).abs() < 1e-4, "cut away: {d}");
        }
        for d in depth_with_screen(0.8) {
            assert!((d - 3.0).abs() < 1e-4, "kept: {d}");
        }
    }

    /// A wall facing the camera at distance 5 fills the frame: every sample
    /// reads depth 5, the plane's depth, not the slant distance along the ray.
    #[test]
    fn a_facing_wall_reads_its_distance_everywhere() {
        let mut scene = looking_along_y(9, 7);
        scene.add_polygon(
            &[
                Vec3::new(-50.0, 5.0, -50.0),
                Vec3::new(50.0, 5.0, -50.0),
                Vec3::new(50.0, 5.0, 50.0),
                Vec3::new(-50.0, 5.0, 50.0),
            ],
            "wall",
        );
        let world = World::new(scene);
        let cam = Camera::new(&world.scene.viewpoint, 9, 7);
        let view = View {
            offset: 0.3,
            shift: -2,
        };
        let pass = depth_pass(&world, &cam, view, 2);
        assert_eq!(pass.columns, vec![0, 2, 4, 6, 8]);
        assert_eq!(pass.rows, vec![0, 2, 4, 6]);
        for (_, _, d) in pass.samples() {
            assert!((d - 5.0).abs() < 1e-4, "{d}");
        }
    }
}

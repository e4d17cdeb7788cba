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

use crate::bvh::TraversalStats;
use crate::math::{reflect, refract, Ray};
use crate::rig::depth_pass::{nearest_hit, nearest_surface};
use crate::rig::{pair_disparity, Camera, Rig, View};
use crate::shading::offset_point;
use crate::shapes::SurfaceHit;
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
        let pixels: Vec<Pixel> = (0..h)
            .into_par_iter()
            .flat_map_iter(|y| {
                let mut stats = TraversalStats::default();
                (0..w)
                    .map(|x| pixel(world, camera, here, neighbour, max_depth, x, y, &mut stats))
                    .collect::<Vec<_>>()
            })
            .collect();
        GroundTruth {
            width: w,
            height: h,
            depth: pixels.iter().map(|p| p.depth).collect(),
            disparity: pixels.iter().map(|p| p.disparity).collect(),
            occluded: pixels.iter().map(|p| p.occluded).collect(),
            out_of_frame: pixels.iter().map(|p| p.out_of_frame).collect(),
            layer2_depth: pixels.iter().map(|p| p.layer2_depth).collect(),
            layer2_disparity: pixels.iter().map(|p| p.layer2_disparity).collect(),
        }
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

/// The ground truth at pixel centre (`x`, `y`) of view `here`.
#[allow(clippy::too_many_arguments)]
fn pixel(
    world: &World,
    camera: &Camera,
    here: View,
    neighbour: Option<Neighbour>,
    max_depth: u32,
    x: u32,
    y: u32,
    stats: &mut TraversalStats,
) -> Pixel {
    let column = (x as i64 + here.shift as i64) as f32;
    let ray = Ray::new(
        camera.eye_at(here.offset),
        camera.direction(column, y as f32),
    );
    let cosine = ray.dir.dot(camera.forward);
    let first = nearest_surface(world, &ray, camera.hither, stats);
    let depth = first.map_or(f32::INFINITY, |(_, hit)| hit.t * cosine);
    let layer2_depth = match first {
        Some((prim, hit)) => second_layer(world, &ray, prim, hit, max_depth, stats)
            .map_or(f32::NAN, |length| length * cosine),
        None => f32::NAN,
    };
    let Some(nb) = neighbour else {
        return Pixel {
            depth,
            disparity: 0.0,
            occluded: false,
            out_of_frame: false,
            layer2_depth,
            layer2_disparity: if layer2_depth.is_nan() { f32::NAN } else { 0.0 },
        };
    };
    let scene_flow = |z: f32| nb.sign * pair_disparity(camera, here, nb.view, f64::from(z));
    let disparity = scene_flow(depth);
    // The point's column in the neighbour: x − d to the right, x + d to the left.
    let there = f64::from(x) + nb.sign * disparity;
    let mut out_of_frame = !(-0.5..f64::from(camera.width) - 0.5).contains(&there);
    let eye = camera.eye_at(nb.view.offset);
    let occluded = match first {
        Some((_, hit)) => {
            let point = ray.at(hit.t);
            if camera.depth_of(point, nb.view.offset) <= camera.hither {
                out_of_frame = true;
                false
            } else {
                let to = point - eye;
                let distance = to.length();
                let back = Ray::new(eye, to / distance);
                nearest_hit(world, &back, camera.hither, stats)
                    < distance * (1.0 - OCCLUSION_MARGIN)
            }
        }
        // The background, at infinity, along the same direction from the neighbour.
        None => nearest_hit(world, &Ray::new(eye, ray.dir), camera.hither, stats).is_finite(),
    };
    Pixel {
        depth,
        disparity: disparity as f32,
        occluded,
        out_of_frame,
        layer2_depth,
        layer2_disparity: if layer2_depth.is_nan() {
            f32::NAN
        } else {
            scene_flow(layer2_depth) as f32
        },
    }
}

/// The length of the path the renderer's ray follows from the eye through
/// mirror and glass surfaces, starting with `hit` on `prim`, to the first
/// surface that is neither (or into the background: infinity); `None` where
/// the first surface is not a mirror or glass.
fn second_layer(
    world: &World,
    eye_ray: &Ray,
    prim: u32,
    hit: SurfaceHit,
    max_depth: u32,
    stats: &mut TraversalStats,
) -> Option<f32> {
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
        match nearest_surface(world, &ray, 0.0, stats) {
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
        let entering = scene.shapes[prim as usize].geometric_normal(point).dot(d) < 0.0;
        let ior = if material.ior > 0.0 {
            material.ior
        } else {
            1.0
        };
        let eta = if entering { 1.0 / ior } else { ior };
        if let Some(dir) = refract(d, facing, eta) {
            return Ray::new(offset_point(point, -off, hit.t), dir);
        }
    }
    Ray::new(offset_point(point, off, hit.t), reflect(d, facing))
}

//! The scene made ready to trace: the hierarchy built, and the shapes stored in
//! the hierarchy's leaf order so that a leaf's primitives sit together in memory.

use std::time::Instant;

use crate::bvh::{self, BuildOptions, Bvh};
use crate::math::{Aabb, Vec3};
use crate::scene::{Material, Scene};
use crate::shapes::{Shape, TriangleNormals};

pub struct World {
    pub scene: Scene,
    /// The hierarchy over every primitive, or with a cut (the paper's section
    /// 2.3) over the primitives nearer than the cut.
    pub bvh: Bvh,
    /// With a cut: the hierarchy over the primitives beyond it. The views' eye
    /// rays see them as the rig's centre does (see `render::twin`); shadow and
    /// secondary rays see them where they are.
    pub far: Option<Bvh>,
    /// Seconds spent building the hierarchy.
    pub build_seconds: f64,
}

/// The paper's section 2.3: objects farther than `depth` along the camera's
/// view direction from the rig's centre `eye` are not twinned.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cut {
    pub eye: Vec3,
    /// Unit view direction.
    pub forward: Vec3,
    pub depth: f32,
}

impl Cut {
    /// A cut at `depth` in front of the camera's eye (the rig's centre).
    pub fn at_depth(camera: &crate::rig::Camera, depth: f32) -> Cut {
        Cut {
            eye: camera.eye,
            forward: camera.forward,
            depth,
        }
    }

    /// Whether all of box `b` lies at a depth of at least `self.depth`.
    pub fn beyond(&self, b: &Aabb) -> bool {
        if b.is_empty() {
            return false;
        }
        let (lo, hi) = (b.min - self.eye, b.max - self.eye);
        let f = self.forward;
        let nearest = (lo.x * f.x).min(hi.x * f.x)
            + (lo.y * f.y).min(hi.y * f.y)
            + (lo.z * f.z).min(hi.z * f.z);
        nearest >= self.depth
    }
}

impl World {
    pub fn new(scene: Scene) -> World {
        World::with_cut(scene, None)
    }

    /// The scene made ready to trace, its object tree cut at `cut` if given.
    /// The cut takes whole groups (the loader's unit: an NFF entity, an OBJ
    /// object, a glTF node), and a group only if all of it lies beyond the cut,
    /// so that objects that touch across the cut stay together.
    pub fn with_cut(mut scene: Scene, cut: Option<Cut>) -> World {
        let start = Instant::now();
        scene.finish();
        let boxes: Vec<Aabb> = scene.shapes.iter().map(|s| s.bounds()).collect();
        let far_groups: Vec<bool> = match cut {
            None => Vec::new(),
            Some(c) => {
                let groups = scene
                    .shape_group
                    .iter()
                    .map(|&g| g as usize + 1)
                    .max()
                    .unwrap_or(0);
                let mut beyond = vec![true; groups];
                for (b, &g) in boxes.iter().zip(&scene.shape_group) {
                    beyond[g as usize] &= c.beyond(b);
                }
                beyond
            }
        };
        let (near, far): (Vec<u32>, Vec<u32>) = (0..boxes.len() as u32).partition(|&i| {
            !far_groups
                .get(scene.shape_group[i as usize] as usize)
                .copied()
                .unwrap_or(false)
        });
        let build = |set: &[u32]| {
            let set_boxes: Vec<Aabb> = set.iter().map(|&i| boxes[i as usize]).collect();
            let mut bvh = bvh::build(&set_boxes, &BuildOptions::default());
            for o in &mut bvh.order {
                *o = set[*o as usize];
            }
            bvh
        };
        let mut bvh = build(&near);
        let mut far_bvh = (!far.is_empty()).then(|| build(&far));
        // Reorder shapes into leaf order (near, then far); the hierarchies then
        // index them directly.
        let mut order = std::mem::take(&mut bvh.order);
        let near_count = order.len() as u32;
        if let Some(f) = &mut far_bvh {
            order.extend(std::mem::take(&mut f.order));
            f.order = (near_count..order.len() as u32).collect();
        }
        let mut shapes = Vec::with_capacity(order.len());
        let mut materials = Vec::with_capacity(order.len());
        let mut groups = Vec::with_capacity(order.len());
        for &i in &order {
            shapes.push(scene.shapes[i as usize].clone());
            materials.push(scene.shape_material[i as usize]);
            groups.push(scene.shape_group[i as usize]);
        }
        scene.shapes = shapes;
        scene.shape_material = materials;
        scene.shape_group = groups;
        bvh.order = (0..near_count).collect();
        World {
            scene,
            bvh,
            far: far_bvh,
            build_seconds: start.elapsed().as_secs_f64(),
        }
    }

    /// Primitives beyond the cut.
    pub fn cut_primitives(&self) -> usize {
        self.far.as_ref().map_or(0, |f| f.order.len())
    }

    /// The transmission coefficient `T` of a primitive's material.
    #[inline]
    pub fn transmission_of(&self, prim: u32) -> f32 {
        self.scene.materials[self.scene.shape_material[prim as usize] as usize].t
    }

    /// The material of a primitive.
    #[inline]
    pub fn material_of(&self, prim: u32) -> &Material {
        &self.scene.materials[self.scene.shape_material[prim as usize] as usize]
    }

    /// Whether primitives `a` and `b` are flat triangles of one plane and one
    /// material (one polygon, or polygons that continue each other): the
    /// "same planar surface" of the paper's section 2.4.
    pub fn coplanar(&self, a: u32, b: u32) -> bool {
        let s = &self.scene;
        let flat = |p: u32| match &s.shapes[p as usize] {
            Shape::Triangle(t) if t.normals == TriangleNormals::Flat => Some(t),
            _ => None,
        };
        let (Some(ta), Some(tb)) = (flat(a), flat(b)) else {
            return false;
        };
        if a == b {
            return true;
        }
        if s.shape_material[a as usize] != s.shape_material[b as usize]
            || ta.face_normal.dot(tb.face_normal) < 1.0 - 1e-6
        {
            return false;
        }
        let scale = ta
            .v0
            .abs()
            .max_element()
            .max(tb.v0.abs().max_element())
            .max(1.0);
        ta.face_normal.dot(tb.v0 - ta.v0).abs() <= 1e-5 * scale
    }

    /// Bytes held by shapes, materials, corner attributes, textures and the hierarchy.
    pub fn memory_bytes(&self) -> usize {
        let s = &self.scene;
        s.shapes.len() * std::mem::size_of::<crate::shapes::Shape>()
            + s.shape_material.len() * 4
            + s.shape_group.len() * 4
            + s.corners.len() * std::mem::size_of::<crate::scene::Corners>()
            + s.materials.len() * std::mem::size_of::<crate::scene::Material>()
            + s.textures.iter().map(|t| t.memory_bytes()).sum::<usize>()
            + self.bvh.memory_bytes()
            + self.far.as_ref().map_or(0, Bvh::memory_bytes)
    }
}

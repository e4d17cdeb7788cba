//! The scene made ready to trace: the hierarchy built, and the shapes stored in
//! the hierarchy's leaf order so that a leaf's primitives sit together in memory.

use std::time::Instant;

use crate::bvh::{self, BuildOptions, Bvh};
use crate::math::Aabb;
use crate::scene::Scene;

pub struct World {
    pub scene: Scene,
    pub bvh: Bvh,
    /// Seconds spent building the hierarchy.
    pub build_seconds: f64,
}

impl World {
    pub fn new(mut scene: Scene) -> World {
        let start = Instant::now();
        scene.finish();
        let boxes: Vec<Aabb> = scene.shapes.iter().map(|s| s.bounds()).collect();
        let mut bvh = bvh::build(&boxes, &BuildOptions::default());
        // Reorder shapes into leaf order; the hierarchy then indexes them directly.
        let order = std::mem::take(&mut bvh.order);
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
        bvh.order = (0..order.len() as u32).collect();
        World {
            scene,
            bvh,
            build_seconds: start.elapsed().as_secs_f64(),
        }
    }

    /// The transmission coefficient `T` of a primitive's material.
    #[inline]
    pub fn transmission_of(&self, prim: u32) -> f32 {
        self.scene.materials[self.scene.shape_material[prim as usize] as usize].t
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
    }
}

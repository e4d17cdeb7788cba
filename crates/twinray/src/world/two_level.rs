//! The scene's hierarchy as instances over meshes, for an animation: one
//! tree per instance (a glTF node instance, its triangles in world space),
//! kept between frames while the instance does not move, and a small tree over
//! the instances' root boxes, joined into one [`Bvh`] by [`bvh::splice`]. A
//! frame in which one node moves builds that node's tree and the top again,
//! not the whole scene's.

use std::ops::Range;
use std::time::Instant;

use rayon::prelude::*;

use super::hierarchy::{build_options, into_leaf_order, InstanceCounts, World};
use crate::bvh::{self, Bvh, Placed};
use crate::math::Aabb;
use crate::scene::Scene;

/// One instance: the scene's shapes `shapes` (a contiguous run), and what
/// its geometry is a function of (`None`: unknown, built every time). Two
/// frames' instances at the same place in the list with equal keys and
/// shape counts have the same shapes: the tree of the first serves the second.
#[derive(Clone, Debug, PartialEq)]
pub struct Instance {
    pub shapes: Range<usize>,
    pub key: Option<Vec<u32>>,
}

/// The instances' trees kept from one frame to the next.
#[derive(Default)]
pub struct InstanceTrees {
    /// By place in the instance list: the key and the tree over the
    /// instance's shapes (its order local to the instance).
    kept: Vec<Option<(Option<Vec<u32>>, Bvh)>>,
}

impl World {
    /// The scene made ready to trace with a two-level hierarchy. `instances`
    /// are contiguous runs of `scene.shapes` in order; shapes after the last
    /// (a `--ground` floor) form one more instance, built every time. Each
    /// instance's tree is taken from `trees` if its key is unchanged, else
    /// built (and kept for the next frame if it has a key).
    pub fn two_level(mut scene: Scene, instances: &[Instance], trees: &mut InstanceTrees) -> World {
        let start = Instant::now();
        scene.finish();
        let n = scene.shapes.len();
        let mut runs: Vec<Instance> = Vec::with_capacity(instances.len() + 1);
        let mut end = 0;
        for i in instances {
            debug_assert_eq!(i.shapes.start, end, "instances are contiguous runs");
            end = i.shapes.end;
            runs.push(i.clone());
        }
        if end < n {
            runs.push(Instance {
                shapes: end..n,
                key: None,
            });
        }
        trees.kept.resize_with(runs.len(), || None);
        let reusable = |i: usize| match (&runs[i].key, &trees.kept[i]) {
            (Some(key), Some((Some(kept), bvh))) => {
                key == kept && bvh.primitive_count() == runs[i].shapes.len()
            }
            _ => false,
        };
        let reuse: Vec<bool> = (0..runs.len()).map(reusable).collect();
        let built: Vec<Option<Bvh>> = runs
            .par_iter()
            .zip(&reuse)
            .map(|(run, &reuse)| {
                (!reuse).then(|| {
                    let shapes = &scene.shapes[run.shapes.clone()];
                    let boxes: Vec<Aabb> = shapes.iter().map(|s| s.bounds()).collect();
                    let mut tree = bvh::build(&boxes, &build_options(shapes.iter()));
                    // Only the joined tree is traversed: its wide form is
                    // made after the splice.
                    tree.wide = Vec::new();
                    tree
                })
            })
            .collect();
        let mut counts = InstanceCounts {
            instances: runs.len(),
            primitives: n,
            ..InstanceCounts::default()
        };
        for (i, tree) in built.into_iter().enumerate() {
            if let Some(tree) = tree {
                counts.rebuilt_instances += 1;
                counts.rebuilt_primitives += runs[i].shapes.len();
                trees.kept[i] = Some((runs[i].key.clone(), tree));
            }
        }
        let parts: Vec<Placed> = runs
            .iter()
            .zip(&trees.kept)
            .map(|(run, kept)| Placed {
                bvh: &kept.as_ref().expect("every instance has a tree").1,
                offset: run.shapes.start as u32,
            })
            .collect();
        let mut joined = bvh::splice(&parts);
        into_leaf_order(&mut scene, std::iter::once(&mut joined));
        World {
            pieces: Default::default(),
            has_alpha: scene.has_alpha(),
            scene,
            bvh: joined,
            far: None,
            build_seconds: start.elapsed().as_secs_f64(),
            instances: Some(counts),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;
    use crate::scene::{AlphaMode, Material, MeshPolygon};

    /// Two triangles of a MASK material, one instance.
    fn masked_scene() -> Scene {
        let mut scene = Scene::new();
        let material = scene.add_material(Material {
            alpha_mode: AlphaMode::Mask { cutoff: 0.5 },
            ..Material::default()
        });
        let group = scene.new_group();
        let quad = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ];
        scene.add_mesh_polygon(
            &MeshPolygon {
                vertices: &quad,
                normals: None,
                uv: None,
                material,
                group,
            },
            &|| "quad".to_string(),
        );
        scene
    }

    /// A two-level world is traced like a whole build's: it knows the
    /// scene's alpha (or cut-outs would be solid in an animation's frames)
    /// and has the triangle blocks of its leaves.
    #[test]
    fn a_two_level_world_knows_alpha_and_has_triangle_blocks() {
        let scene = masked_scene();
        let whole = World::new(scene.clone());
        let n = scene.shapes.len();
        let instances = [Instance {
            shapes: 0..n,
            key: Some(vec![1]),
        }];
        let two = World::two_level(scene, &instances, &mut InstanceTrees::default());
        assert!(whole.has_alpha);
        assert_eq!(two.has_alpha, whole.has_alpha);
        assert!(!two.bvh.blocks.is_empty());
        assert_eq!(two.bvh.blocks.triangles(), whole.bvh.blocks.triangles());
    }
}

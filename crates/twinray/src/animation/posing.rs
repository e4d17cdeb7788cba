//! The frames of an animated glTF file: the file read once and posed at each
//! frame's time. An instance whose node did not move (the same world
//! transform and morph weights) keeps its triangles and its tree from the
//! frame before; the moving ones are made from the file's buffers and built
//! again, with the small tree over all instances ([`World::two_level`]).

use std::sync::Arc;
use std::time::Instant;

use crate::job::{Job, Loaded};
use crate::loaders::gltf::{GltfFile, PosedInstance};
use crate::scene::Scene;
use crate::world::{Instance, InstanceTrees, World};
use crate::Result;

pub(crate) struct Posing {
    file: GltfFile,
    /// The last frame's scene (the model's shapes first) and its instances.
    previous: Option<(Arc<Scene>, Vec<PosedInstance>)>,
    trees: InstanceTrees,
}

impl Posing {
    /// Reads the job's scene file.
    pub fn open(job: &Job) -> Result<Posing> {
        Ok(Posing {
            file: GltfFile::open(&job.spec().scene, &job.load_options(None))?,
            previous: None,
            trees: InstanceTrees::default(),
        })
    }

    /// The scene at `time` seconds, readied by `job` as [`Job::load_at`]
    /// readies it, with its two-level hierarchy built.
    pub fn loaded_at(&mut self, job: &Job, time: f32) -> Result<Loaded> {
        let start = Instant::now();
        let previous = self.previous.as_ref().map(|(s, p)| (&**s, &p[..]));
        let posed = self.file.pose(Some(time), previous)?;
        let load_seconds = start.elapsed().as_secs_f64();
        let mut loaded = job.prepare(posed.scene)?;
        loaded.load_seconds = load_seconds;
        let instances: Vec<Instance> = posed
            .instances
            .iter()
            .map(|p| Instance {
                shapes: p.shapes.clone(),
                key: Some(p.key.clone()),
            })
            .collect();
        let trees = &mut self.trees;
        let mut world = job
            .pool()
            .install(|| World::two_level((*loaded.scene).clone(), &instances, trees));
        if let Some(c) = &mut world.instances {
            c.made_primitives = posed.made_triangles;
        }
        loaded.set_world(Arc::new(world));
        self.previous = Some((loaded.scene.clone(), posed.instances));
        Ok(loaded)
    }
}

//! Shadow fans (`--share-shading`): the shadow segments of several surface
//! points toward one point light proved free by one descent
//! (`bvh::ShadowFan`), in the whole scene (both sides of a cut).

use super::Tracer;
use crate::bvh::{FanWork, ShadowFan};
use crate::math::Vec3;

impl Tracer<'_> {
    /// Whether no segment `origins[l] → light` can meet any primitive of the
    /// scene (conservative: `true` is proved; see `bvh::wedge`). `end_error`
    /// bounds how far a shadow ray's computed end lies from `light`.
    pub fn fan_is_free(&mut self, origins: &[Vec3], light: Vec3, end_error: f32) -> bool {
        self.is_free(ShadowFan::new(origins, light, end_error))
    }

    /// [`Tracer::fan_is_free`] for the segments of two ends and of every
    /// point between them (`ShadowFan::spanning`).
    pub fn span_is_free(&mut self, ends: &[Vec3; 2], light: Vec3, end_error: f32) -> bool {
        self.is_free(ShadowFan::spanning(ends, light, end_error))
    }

    fn is_free(&mut self, fan: Option<ShadowFan>) -> bool {
        let Some(fan) = fan else {
            return false;
        };
        let world = self.world;
        let shapes = &world.scene.shapes;
        let mut work = FanWork::default();
        let free = world.bvh.fan_is_free(&fan, shapes, &mut work)
            && world
                .far
                .as_ref()
                .is_none_or(|far| far.fan_is_free(&fan, shapes, &mut work));
        self.counts.fan_queries += 1;
        self.counts.fan_free += u64::from(free);
        self.counts.nodes += work.nodes;
        free
    }
}

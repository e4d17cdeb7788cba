//! The paper's section 2.4, merged secondary rays (approximate, a
//! technique of the twin method and a stage of the fast method): the
//! views' reflected (refracted) rays from one planar surface traced as one
//! ray from the midpoint of their origins.

use super::{ShadingTree, Spawn, Surfaces, Tracer};
use crate::bvh::Packet;
use crate::math::{Color, Vec3};

impl<'a> Tracer<'a> {
    /// The paper's section 2.4 (approximate): lanes whose hits lie on one planar
    /// surface (of one material) trace one ray for all of them, from the
    /// midpoint of their origins along their mean direction (the paper's two
    /// parallel rays, one ray between them); its colour goes to each of them.
    /// The other lanes trace their own rays, as one packet.
    pub(super) fn trace_spawned_merged<const K: usize>(
        &mut self,
        s: &Surfaces<'a, K>,
        spawns: &[Option<Spawn>; K],
        level: u32,
        weights: &[f32; K],
        tree: &mut ShadingTree,
    ) -> [Color; K] {
        let mut rest = *spawns;
        let mut out = [Color::ZERO; K];
        let mut lanes = spawns
            .iter()
            .enumerate()
            .filter(|(_, s)| s.is_some())
            .fold(0u32, |m, (l, _)| m | 1 << l);
        while lanes != 0 {
            let l = lanes.trailing_zeros() as usize;
            lanes &= lanes - 1;
            let mut members = 1u32 << l;
            let mut others = lanes;
            while others != 0 {
                let m = others.trailing_zeros() as usize;
                others &= others - 1;
                if tree.one_group::<K>(l, m) && self.world.coplanar(s.prims[l], s.prims[m]) {
                    members |= 1 << m;
                }
            }
            if members.count_ones() < 2 {
                continue;
            }
            lanes &= !members;
            let (mut origin, mut dir, mut weight) = (Vec3::ZERO, Vec3::ZERO, 0.0f32);
            let mut each = members;
            while each != 0 {
                let m = each.trailing_zeros() as usize;
                each &= each - 1;
                if let Some(sp) = spawns[m] {
                    origin += sp.origin;
                    dir += sp.dir;
                    weight = weight.max(weights[m] * sp.coefficient);
                }
            }
            let dir = dir.normalize_or_zero();
            if dir == Vec3::ZERO {
                continue; // opposite directions: nothing to merge, trace them apart
            }
            let count = members.count_ones();
            let single = Packet::ray(origin / count as f32, dir);
            let above = tree.single;
            tree.single = tree.top_lanes::<K>(members);
            let c = self.trace::<1>(&single, level, [weight], tree)[0];
            tree.single = above;
            self.counts.paper.merged_rays += (count - 1) as u64;
            let mut each = members;
            while each != 0 {
                let m = each.trailing_zeros() as usize;
                each &= each - 1;
                out[m] = c;
                rest[m] = None;
            }
        }
        if rest.iter().any(Option::is_some) {
            let c = self.trace_spawned(&rest, level, weights, tree);
            for l in 0..K {
                if rest[l].is_some() {
                    out[l] = c[l];
                }
            }
        }
        out
    }
}
